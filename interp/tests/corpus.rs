//! Behaviours found by running real public URScript programs (not in this repository)
//! through the `check` example; each test is written for this project in the style of
//! those programs.
mod common;
use common::{messages, runtime_error};

/// An admittance loop in the style of UR's own examples: a diagonal mass matrix built
/// from a list, inverted, and multiplied by a wrench error (a list), then integrated
/// element by element. `matrix * list` is the matrix product, a list.
#[test]
fn matrix_times_list_is_the_matrix_product() {
    let src = "\
def diag3(v):
  return [[v[0], 0, 0], [0, v[1], 0], [0, 0, v[2]]]
end
def admittance_step():
  local M = diag3([2, 4, 8])
  local D = diag3([1, 1, 1]) * 0.5
  local err = [4.0, 8.0, 16.0]
  local dx = [2.0, 0.0, -2.0]
  local ddx = inv(M) * (err - (D * dx))
  textmsg(ddx)
  local vel = [1, 1, 1] * ddx
  textmsg(vel)
  textmsg(M * [[1, 0], [0, 1], [1, 1]])
  textmsg([1, 2, 3] * [2, 2, 2])
end
admittance_step()
";
    let m = messages(src);
    assert_eq!(m[0], "[1.5, 2, 2.125]");
    assert_eq!(m[1], "[1.5, 2, 2.125]");
    assert_eq!(m[2], "[[2, 0], [0, 4], [8, 8]]");
    assert_eq!(m[3], "[2, 4, 6]");
}

#[test]
fn matrix_product_of_mismatched_shapes_is_a_runtime_error() {
    let e = runtime_error("m = [[1, 2], [3, 4]]\nv = m * [1, 2, 3]\n");
    assert!(e.contains("matrix product"), "{e}");
    let e = runtime_error("m = [[1, 2], [3]]\nv = m * [1, 2]\n");
    assert!(e.contains("matrix product"), "{e}");
    let e = runtime_error("m = [[]]\nv = m * []\n");
    assert!(e.contains("matrix product"), "{e}");
}

/// A CB3-era program header, as PolyScope 3.0-3.2 and python-urx write it: the
/// deprecated `set_runstate_outputs` is a built-in, with or without its list.
#[test]
fn cb3_header_with_set_runstate_outputs_runs() {
    let src = "\
def gripper_prog():
\tset_analog_inputrange(0, 0)
\tset_analog_outputdomain(0, 0)
\tset_tool_voltage(0)
\tset_runstate_outputs([])
\tset_runstate_outputs()
\tset_payload(1.1)
\ttextmsg(\"header done\")
end
";
    assert_eq!(messages(src), vec!["header done".to_string()]);
}
