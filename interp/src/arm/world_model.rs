//! The world model (`add_frame`, `attach_frame`, `get_pose`, `convert_pose`, ...): a tree
//! of named coordinate frames on the virtual controller, as UR describes it for PolyScope
//! 5.x (the World Model API of its MotionPlus documentation; see the package README,
//! "World model", for what UR's text says and what is this model's choice).
//!
//! - `world` is the root. `base` (the robot's base) hangs under it, at the world origin
//!   until moved (`move_frame("base", ...)`) or attached; `reset_world_model()` puts it
//!   back. `flange` hangs under `base` and `tcp` under `flange`: they follow the arm (the
//!   flange where the joints put it now, the TCP at the active TCP offset), never stored.
//! - An added frame keeps its placement relative to its parent: a frame attached to `tcp`
//!   moves with the arm, one under `world` stays where it was put.
//! - The model belongs to the arm ([`Arm`](crate::Arm)): it persists across programs run
//!   on the same arm until `reset_world_model()`, as UR describes.
//!
//! ## Choices where UR's text is silent
//! - `get_pose(name, rel_frame, ref_frame)`: the transform from `rel_frame` to `name`,
//!   expressed in `ref_frame`'s axes: its translation is `name`'s origin minus
//!   `rel_frame`'s, in `ref_frame`'s axes, and its rotation is the rotation from
//!   `rel_frame` to `name` seen in `ref_frame`'s axes (`R_ref^T R_name R_rel^T R_ref`).
//!   With `ref_frame` left out (or equal to `rel_frame`) this is `pose_trans(pose_inv(W_rel),
//!   W_name)`, `W` being a frame's pose in the world.
//! - `convert_pose(pose, from_frame, to_frame)`: a pose given in `from_frame`, the same
//!   pose given in `to_frame`: `pose_trans(pose_inv(W_to), pose_trans(W_from, pose))`.
//! - `attach_frame` refuses `world`, `flange` and `tcp` as the child (UR's list) and a
//!   parent under the child (a closed chain); `base` may be attached (a robot on a moving
//!   platform), and then the arm's frames move with it.
//! - `delete_frame` of a frame with children attaches them to `world` where they are (as
//!   UR says `delete_all_frames` does). Frames named `world`, `base`, `flange`, `tcp`
//!   cannot be deleted, moved (but `base`), or given mass properties.
//! - `frame_tracking_enable(name)` / `frame_tracking_disable()` record which frame is
//!   tracked; frames move here only by `move_frame` or with the arm, so a tracked frame
//!   changes no motion (documented, not modelled).
//! - `set_payload_from_attached_frames()`: the payload becomes the frames under `tcp` or
//!   `flange` (at any depth) that have mass properties: their total mass, their common
//!   centre of gravity in the flange frame, and their inertia about it in the flange's
//!   axes (each rotated into the flange's axes, then moved by the parallel axis theorem);
//!   no such frame: no payload (mass 0).
//!
//! ## Bounds
//! At most [`MAX_FRAMES`] added frames, names of 1 to [`MAX_NAME_LEN`] bytes: past
//! either, a runtime error naming the function.

use crate::arm::pose;

/// The most frames a program may add.
pub const MAX_FRAMES: usize = 256;
/// The longest frame name.
pub const MAX_NAME_LEN: usize = 64;

/// The names of the frames every model has.
pub const RESERVED: [&str; 4] = ["world", "base", "flange", "tcp"];

/// Mass properties of a frame (`set_mass_properties`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Mass {
    m: f64,
    cog: [f64; 3],
    /// `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` about the CoG, in the frame's axes.
    inertia: [f64; 6],
}

#[derive(Debug, Clone, PartialEq)]
struct Frame {
    name: String,
    parent: String,
    /// Placement relative to the parent.
    pose: [f64; 6],
    mass: Option<Mass>,
}

/// The world model's state (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct WorldModel {
    /// `base`'s parent and placement in it.
    base_parent: String,
    base_pose: [f64; 6],
    /// Added frames, in the order added.
    frames: Vec<Frame>,
    tracking: Option<String>,
}

impl Default for WorldModel {
    fn default() -> Self {
        WorldModel {
            base_parent: "world".into(),
            base_pose: [0.0; 6],
            frames: Vec::new(),
            tracking: None,
        }
    }
}

/// Where the arm is now: the flange in the base frame, the TCP offset from the flange.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ArmNow {
    pub flange: [f64; 6],
    pub tcp: [f64; 6],
}

/// The payload `set_payload_from_attached_frames` computes: mass (kg), CoG (m, flange
/// frame), inertia `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (kg·m², about the CoG).
pub(crate) type Payload = (f64, [f64; 3], [f64; 6]);

fn finite(p: [f64; 6], what: &str) -> Result<[f64; 6], String> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(p)
    } else {
        Err(format!("{what} must be finite numbers"))
    }
}

impl WorldModel {
    fn frame(&self, name: &str) -> Option<&Frame> {
        self.frames.iter().find(|f| f.name == name)
    }

    fn frame_mut(&mut self, name: &str) -> Option<&mut Frame> {
        self.frames.iter_mut().find(|f| f.name == name)
    }

    /// True if `name` is a frame of the model.
    pub fn is_frame(&self, name: &str) -> bool {
        RESERVED.contains(&name) || self.frame(name).is_some()
    }

    fn unknown(name: &str) -> String {
        format!("no frame \"{}\" in the world model", clip(name))
    }

    /// The parent of `name` (`None` for `world` or an unknown name).
    fn parent_of(&self, name: &str) -> Option<&str> {
        match name {
            "world" => None,
            "base" => Some(&self.base_parent),
            "flange" => Some("base"),
            "tcp" => Some("flange"),
            _ => self.frame(name).map(|f| f.parent.as_str()),
        }
    }

    /// `name`'s placement in its parent.
    fn local(&self, name: &str, arm: ArmNow) -> Option<[f64; 6]> {
        match name {
            "world" => Some([0.0; 6]),
            "base" => Some(self.base_pose),
            "flange" => Some(arm.flange),
            "tcp" => Some(arm.tcp),
            _ => self.frame(name).map(|f| f.pose),
        }
    }

    /// `name`'s pose in the world.
    pub fn world_pose(&self, name: &str, arm: ArmNow) -> Result<[f64; 6], String> {
        let mut chain = Vec::new();
        let mut at = name;
        // The tree is acyclic (attach_frame refuses a closed chain); the bound is a guard.
        for _ in 0..MAX_FRAMES + RESERVED.len() + 1 {
            if at == "world" {
                return Ok(chain
                    .iter()
                    .rev()
                    .fold([0.0; 6], |acc, p| pose::trans(acc, *p)));
            }
            chain.push(self.local(at, arm).ok_or_else(|| Self::unknown(at))?);
            at = self.parent_of(at).ok_or_else(|| Self::unknown(at))?;
        }
        Err("the world model's frames form a loop".into())
    }

    /// True if `ancestor` is `name` or above it.
    fn is_under(&self, name: &str, ancestor: &str) -> bool {
        let mut at = name;
        for _ in 0..MAX_FRAMES + RESERVED.len() + 1 {
            if at == ancestor {
                return true;
            }
            match self.parent_of(at) {
                Some(p) => at = p,
                None => return false,
            }
        }
        true
    }

    fn check_new_name(&self, name: &str) -> Result<(), String> {
        if name.is_empty() || name.len() > MAX_NAME_LEN {
            return Err(format!(
                "a frame name must be 1 to {MAX_NAME_LEN} bytes, got {} bytes",
                name.len()
            ));
        }
        if self.is_frame(name) {
            return Err(format!("a frame named \"{name}\" already exists"));
        }
        if self.frames.len() >= MAX_FRAMES {
            return Err(format!(
                "the world model holds at most {MAX_FRAMES} added frames"
            ));
        }
        Ok(())
    }

    /// `add_frame(name, pose, ref_frame)`.
    pub fn add(
        &mut self,
        name: &str,
        p: [f64; 6],
        reference: &str,
        arm: ArmNow,
    ) -> Result<(), String> {
        self.check_new_name(name)?;
        let p = finite(p, "the pose")?;
        let at = pose::trans(self.world_pose(reference, arm)?, p);
        self.frames.push(Frame {
            name: name.into(),
            parent: "world".into(),
            pose: at,
            mass: None,
        });
        Ok(())
    }

    /// `attach_frame(child, parent)`: the child keeps its place in the world.
    pub fn attach(&mut self, child: &str, parent: &str, arm: ArmNow) -> Result<(), String> {
        if matches!(child, "world" | "flange" | "tcp") {
            return Err(format!("\"{child}\" cannot be attached to another frame"));
        }
        if !self.is_frame(child) {
            return Err(Self::unknown(child));
        }
        if !self.is_frame(parent) {
            return Err(Self::unknown(parent));
        }
        if self.is_under(parent, child) {
            return Err(format!(
                "attaching \"{child}\" to \"{parent}\" would close a chain (\"{parent}\" is \"{child}\" or under it)"
            ));
        }
        let local = pose::trans(
            pose::inv(self.world_pose(parent, arm)?),
            self.world_pose(child, arm)?,
        );
        if child == "base" {
            self.base_parent = parent.into();
            self.base_pose = local;
        } else if let Some(f) = self.frame_mut(child) {
            f.parent = parent.into();
            f.pose = local;
        }
        Ok(())
    }

    /// Attaches `name`'s children to `world` where they are.
    fn orphan_children_of(&mut self, name: &str, arm: ArmNow) -> Result<(), String> {
        let children: Vec<String> = self
            .children(name)
            .into_iter()
            .filter(|c| !RESERVED.contains(&c.as_str()))
            .collect();
        for c in children {
            let w = self.world_pose(&c, arm)?;
            if let Some(f) = self.frame_mut(&c) {
                f.parent = "world".into();
                f.pose = w;
            }
        }
        if self.base_parent == name {
            self.base_pose = self.world_pose("base", arm)?;
            self.base_parent = "world".into();
        }
        Ok(())
    }

    /// `delete_frame(name)`.
    pub fn delete(&mut self, name: &str, arm: ArmNow) -> Result<(), String> {
        if RESERVED.contains(&name) {
            return Err(format!("\"{name}\" cannot be deleted"));
        }
        if self.frame(name).is_none() {
            return Err(Self::unknown(name));
        }
        self.orphan_children_of(name, arm)?;
        self.frames.retain(|f| f.name != name);
        if self.tracking.as_deref() == Some(name) {
            self.tracking = None;
        }
        Ok(())
    }

    /// `delete_all_frames()`: `base` stays where it is in the world.
    pub fn delete_all(&mut self, arm: ArmNow) -> Result<(), String> {
        if self.base_parent != "world" {
            self.base_pose = self.world_pose("base", arm)?;
            self.base_parent = "world".into();
        }
        self.frames.clear();
        self.tracking = None;
        Ok(())
    }

    /// `reset_world_model()`.
    pub fn reset(&mut self) {
        *self = WorldModel::default();
    }

    /// `move_frame(name, pose, ref_frame)`.
    pub fn move_to(
        &mut self,
        name: &str,
        p: [f64; 6],
        reference: &str,
        arm: ArmNow,
    ) -> Result<(), String> {
        if matches!(name, "world" | "flange" | "tcp") {
            return Err(format!("\"{name}\" cannot be moved"));
        }
        if !self.is_frame(name) {
            return Err(Self::unknown(name));
        }
        let p = finite(p, "the pose")?;
        let target = pose::trans(self.world_pose(reference, arm)?, p);
        let parent = self.parent_of(name).unwrap_or("world").to_string();
        let local = pose::trans(pose::inv(self.world_pose(&parent, arm)?), target);
        if name == "base" {
            self.base_pose = local;
        } else if let Some(f) = self.frame_mut(name) {
            f.pose = local;
        }
        Ok(())
    }

    /// `get_pose(name, rel_frame, ref_frame)`.
    pub fn get_pose(
        &self,
        name: &str,
        rel: &str,
        reference: &str,
        arm: ArmNow,
    ) -> Result<[f64; 6], String> {
        let w_name = self.world_pose(name, arm)?;
        let w_rel = self.world_pose(rel, arm)?;
        if reference == rel {
            return Ok(pose::trans(pose::inv(w_rel), w_name));
        }
        let w_ref = self.world_pose(reference, arm)?;
        let r_ref = pose::to_matrix([w_ref[3], w_ref[4], w_ref[5]]);
        let r_rel = pose::to_matrix([w_rel[3], w_rel[4], w_rel[5]]);
        let r_name = pose::to_matrix([w_name[3], w_name[4], w_name[5]]);
        let d = [
            w_name[0] - w_rel[0],
            w_name[1] - w_rel[1],
            w_name[2] - w_rel[2],
        ];
        let t = pose::apply(pose::transpose(r_ref), d);
        let r = pose::mul(
            pose::mul(
                pose::transpose(r_ref),
                pose::mul(r_name, pose::transpose(r_rel)),
            ),
            r_ref,
        );
        let rv = pose::to_rotvec(r);
        Ok([t[0], t[1], t[2], rv[0], rv[1], rv[2]])
    }

    /// `convert_pose(pose, from_frame, to_frame)`.
    pub fn convert(
        &self,
        p: [f64; 6],
        from: &str,
        to: &str,
        arm: ArmNow,
    ) -> Result<[f64; 6], String> {
        let p = finite(p, "the pose")?;
        Ok(pose::trans(
            pose::inv(self.world_pose(to, arm)?),
            pose::trans(self.world_pose(from, arm)?, p),
        ))
    }

    /// `get_frame_parent(name)`.
    pub fn parent(&self, name: &str) -> Result<String, String> {
        if name == "world" {
            return Err("\"world\" is the root: it has no parent".into());
        }
        self.parent_of(name)
            .map(str::to_string)
            .ok_or_else(|| Self::unknown(name))
    }

    /// The immediate children of `name`: the arm's own frame first, then added frames in
    /// the order added.
    pub fn children(&self, name: &str) -> Vec<String> {
        let mut out = Vec::new();
        match name {
            "base" => out.push("flange".to_string()),
            "flange" => out.push("tcp".to_string()),
            _ => {}
        }
        if self.base_parent == name {
            out.push("base".to_string());
        }
        out.extend(
            self.frames
                .iter()
                .filter(|f| f.parent == name)
                .map(|f| f.name.clone()),
        );
        out
    }

    /// `get_children(name)`.
    pub fn get_children(&self, name: &str) -> Result<Vec<String>, String> {
        if !self.is_frame(name) {
            return Err(Self::unknown(name));
        }
        Ok(self.children(name))
    }

    /// `frame_tracking_enable(name)` (`Some`) or `frame_tracking_disable()` (`None`).
    pub fn track(&mut self, name: Option<&str>) -> Result<(), String> {
        if let Some(n) = name {
            if !self.is_frame(n) {
                return Err(Self::unknown(n));
            }
        }
        self.tracking = name.map(str::to_string);
        Ok(())
    }

    /// The frame tracked, if one is.
    #[allow(dead_code)]
    pub fn tracking(&self) -> Option<&str> {
        self.tracking.as_deref()
    }

    /// `set_mass_properties(frame, m, cog, inertia)`.
    pub fn set_mass(
        &mut self,
        name: &str,
        m: f64,
        cog: [f64; 3],
        inertia: [f64; 6],
    ) -> Result<(), String> {
        if RESERVED.contains(&name) {
            return Err(format!(
                "\"{name}\" cannot have mass properties (add a frame for the part)"
            ));
        }
        if !(m.is_finite() && m >= 0.0) {
            return Err(format!("the mass must be a number of at least 0, got {m}"));
        }
        if !cog.iter().chain(inertia.iter()).all(|x| x.is_finite()) {
            return Err("the centre of gravity and inertia must be finite numbers".into());
        }
        let f = self.frame_mut(name).ok_or_else(|| Self::unknown(name))?;
        f.mass = Some(Mass { m, cog, inertia });
        Ok(())
    }

    /// `set_payload_from_attached_frames()`: the payload of the frames under the flange.
    pub fn payload(&self, arm: ArmNow) -> Result<Payload, String> {
        let w_flange = self.world_pose("flange", arm)?;
        let to_flange = pose::inv(w_flange);
        let mut parts = Vec::new();
        for f in &self.frames {
            let Some(mass) = f.mass else { continue };
            if !self.is_under(&f.name, "flange") {
                continue;
            }
            let in_flange = pose::trans(to_flange, self.world_pose(&f.name, arm)?);
            let r = pose::to_matrix([in_flange[3], in_flange[4], in_flange[5]]);
            let c = pose::apply(r, mass.cog);
            let c = [
                c[0] + in_flange[0],
                c[1] + in_flange[1],
                c[2] + in_flange[2],
            ];
            let [xx, yy, zz, xy, xz, yz] = mass.inertia;
            let i = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
            let i = pose::mul(pose::mul(r, i), pose::transpose(r));
            parts.push((mass.m, c, i));
        }
        let total: f64 = parts.iter().map(|p| p.0).sum();
        if total <= 0.0 {
            return Ok((0.0, [0.0; 3], [0.0; 6]));
        }
        let mut cog = [0.0; 3];
        for (m, c, _) in &parts {
            for k in 0..3 {
                cog[k] += m * c[k] / total;
            }
        }
        let mut inertia = [[0.0; 3]; 3];
        for (m, c, i) in &parts {
            let d = [c[0] - cog[0], c[1] - cog[1], c[2] - cog[2]];
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            for a in 0..3 {
                for b in 0..3 {
                    let eye = if a == b { 1.0 } else { 0.0 };
                    inertia[a][b] += i[a][b] + m * (dd * eye - d[a] * d[b]);
                }
            }
        }
        Ok((
            total,
            cog,
            [
                inertia[0][0],
                inertia[1][1],
                inertia[2][2],
                inertia[0][1],
                inertia[0][2],
                inertia[1][2],
            ],
        ))
    }
}

fn clip(s: &str) -> String {
    s.chars().take(MAX_NAME_LEN).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const ARM: ArmNow = ArmNow {
        flange: [0.3, -0.2, 0.5, 0.0, 3.0, 0.0],
        tcp: [0.0, 0.0, 0.1, 0.0, 0.0, 0.0],
    };

    fn close(a: [f64; 6], b: [f64; 6]) {
        let w = |p: [f64; 6]| {
            let r = pose::to_matrix([p[3], p[4], p[5]]);
            (p, r)
        };
        let ((pa, ra), (pb, rb)) = (w(a), w(b));
        for k in 0..3 {
            assert!((pa[k] - pb[k]).abs() < 1e-9, "{a:?} vs {b:?}");
            for j in 0..3 {
                assert!((ra[k][j] - rb[k][j]).abs() < 1e-9, "{a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn frames_keep_their_place_when_attached_and_follow_their_parent() {
        let mut w = WorldModel::default();
        w.add("table", [1.0, 0.0, 0.0, 0.0, 0.0, 1.0], "base", ARM)
            .unwrap();
        w.add("part", [0.1, 0.0, 0.0, 0.0, 0.0, 0.0], "table", ARM)
            .unwrap();
        let before = w.world_pose("part", ARM).unwrap();
        w.attach("part", "tcp", ARM).unwrap();
        close(w.world_pose("part", ARM).unwrap(), before);
        // The arm moves: the part goes with the TCP.
        let moved = ArmNow {
            flange: [0.4, -0.2, 0.5, 0.0, 3.0, 0.0],
            ..ARM
        };
        let after = w.world_pose("part", moved).unwrap();
        assert!((after[0] - before[0] - 0.1).abs() < 1e-9);
        assert_eq!(w.parent("part").unwrap(), "tcp");
        assert_eq!(w.get_children("tcp").unwrap(), ["part"]);
        assert_eq!(w.get_children("world").unwrap(), ["base", "table"]);
        // A closed chain and the arm's frames are refused.
        assert!(w.attach("table", "part", ARM).is_ok());
        assert!(w.attach("part", "table", ARM).is_err());
        assert!(w.attach("tcp", "table", ARM).is_err());
        assert!(w.add("table", [0.0; 6], "base", ARM).is_err());
        assert!(w.delete("flange", ARM).is_err());
        // Deleting the part's parent leaves the table where it is, under world.
        let table = w.world_pose("table", ARM).unwrap();
        w.delete("part", ARM).unwrap();
        close(w.world_pose("table", ARM).unwrap(), table);
        assert_eq!(w.parent("table").unwrap(), "world");
    }

    #[test]
    fn get_pose_and_convert_pose_agree() {
        let mut w = WorldModel::default();
        w.add("a", [0.2, 0.1, 0.0, 0.3, -0.2, 0.5], "world", ARM)
            .unwrap();
        w.add("b", [-0.1, 0.4, 0.2, 1.0, 0.0, 0.2], "world", ARM)
            .unwrap();
        let rel = w.get_pose("b", "a", "a", ARM).unwrap();
        // b relative to a, given in a, converted into world, is b.
        close(
            w.convert(rel, "a", "world", ARM).unwrap(),
            w.world_pose("b", ARM).unwrap(),
        );
        // Expressed in world axes: the translation is the plain difference.
        let in_world = w.get_pose("b", "a", "world", ARM).unwrap();
        let (wa, wb) = (
            w.world_pose("a", ARM).unwrap(),
            w.world_pose("b", ARM).unwrap(),
        );
        for k in 0..3 {
            assert!((in_world[k] - (wb[k] - wa[k])).abs() < 1e-12);
        }
        assert!(w.get_pose("nope", "a", "a", ARM).is_err());
    }

    #[test]
    fn payload_of_attached_frames() {
        let mut w = WorldModel::default();
        // Two 1 kg parts 0.1 m either side of the flange's z axis, on a frame at the TCP.
        w.add("grip", [0.0; 6], "tcp", ARM).unwrap();
        w.attach("grip", "tcp", ARM).unwrap();
        w.set_mass("grip", 1.0, [0.1, 0.0, 0.0], [0.0; 6]).unwrap();
        w.add("other", [0.0; 6], "tcp", ARM).unwrap();
        w.attach("other", "tcp", ARM).unwrap();
        w.set_mass("other", 1.0, [-0.1, 0.0, 0.0], [0.0; 6])
            .unwrap();
        w.add("loose", [0.0; 6], "world", ARM).unwrap();
        w.set_mass("loose", 5.0, [0.0; 3], [0.0; 6]).unwrap();
        let (m, cog, i) = w.payload(ARM).unwrap();
        assert!((m - 2.0).abs() < 1e-12);
        // Both at the TCP's z (0.1 from the flange).
        assert!(cog[0].abs() < 1e-9 && cog[1].abs() < 1e-9 && (cog[2] - 0.1).abs() < 1e-9);
        // Two point masses at ±0.1 m on x: Iyy = Izz = 2 * 1 * 0.01, Ixx = 0.
        assert!(i[0].abs() < 1e-12 && (i[1] - 0.02).abs() < 1e-12 && (i[2] - 0.02).abs() < 1e-12);
        assert!(w.set_mass("tcp", 1.0, [0.0; 3], [0.0; 6]).is_err());
        assert!(w.set_mass("grip", -1.0, [0.0; 3], [0.0; 6]).is_err());
    }

    #[test]
    fn bounds_and_reset() {
        let mut w = WorldModel::default();
        for i in 0..MAX_FRAMES {
            w.add(&format!("f{i}"), [0.0; 6], "world", ARM).unwrap();
        }
        assert!(w
            .add("one_more", [0.0; 6], "world", ARM)
            .unwrap_err()
            .contains("at most"));
        assert!(w
            .add(&"x".repeat(MAX_NAME_LEN + 1), [0.0; 6], "world", ARM)
            .is_err());
        w.move_to("base", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0], "world", ARM)
            .unwrap();
        w.reset();
        assert_eq!(w, WorldModel::default());
        assert!(w
            .add("nan", [f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0], "world", ARM)
            .is_err());
    }
}
