//! `.urp` files for the controller's tests, written here: gzip-compressed XML as
//! PolyScope saves it, a main program holding the given nodes.

use std::io::Write;

/// A `.urp` named `name` whose main program is `nodes` (XML of program nodes).
pub fn urp(name: &str, nodes: &str) -> Vec<u8> {
    let xml = format!(
        r#"<URProgram name="{name}" installation="default" createdIn="5.21.0">
  <children>
    <MainProgram runOnlyOnce="true">
      <children>
        {nodes}
      </children>
    </MainProgram>
  </children>
</URProgram>"#
    );
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(xml.as_bytes()).expect("gzip into memory");
    gz.finish().expect("gzip into memory")
}
