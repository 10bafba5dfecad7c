//! The world model functions (UR's World Model API for PolyScope 5.x, with MotionPlus):
//! named frames on the virtual controller, kept by the arm across programs. The model,
//! its choices and bounds are in [`crate::world_model`].

use super::{opt, req, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;
use crate::world_model::ArmNow;

const D: Domain = Domain::Poses;

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "add_frame",
        D,
        &[req("name"), req("pose"), opt("ref_frame", Default::Str("base"))],
        "Adds frame `name` at `pose` given in `ref_frame`, under world.",
        add_frame,
    ),
    Builtin::new(
        "attach_frame",
        D,
        &[req("child"), req("parent")],
        "Attaches frame `child` to `parent`, keeping its place in the world.",
        attach_frame,
    ),
    Builtin::new(
        "delete_frame",
        D,
        &[req("name")],
        "Deletes an added frame; its children stay where they are, under world.",
        delete_frame,
    ),
    Builtin::new(
        "delete_all_frames",
        D,
        &[],
        "Deletes every added frame (world, base, flange and tcp stay).",
        delete_all_frames,
    ),
    Builtin::new(
        "move_frame",
        D,
        &[req("name"), req("pose"), opt("ref_frame", Default::Str("base"))],
        "Moves frame `name` (its children with it) to `pose` given in `ref_frame`.",
        move_frame,
    ),
    Builtin::new(
        "get_pose",
        D,
        &[req("name"), req("rel_frame"), opt("ref_frame", Default::Absent)],
        "The pose of frame `name` relative to `rel_frame`, in `ref_frame`'s axes (default: rel_frame's).",
        get_pose,
    ),
    Builtin::new(
        "convert_pose",
        D,
        &[req("pose"), req("from_frame"), req("to_frame")],
        "A pose given in `from_frame`, given in `to_frame`.",
        convert_pose,
    ),
    Builtin::new(
        "reset_world_model",
        D,
        &[],
        "Deletes every added frame and puts base back at the world origin.",
        reset_world_model,
    ),
    Builtin::new(
        "is_frame",
        D,
        &[req("name")],
        "True if the world model has a frame `name`.",
        is_frame,
    ),
    Builtin::new(
        "get_frame_parent",
        D,
        &[req("name")],
        "The name of frame `name`'s parent.",
        get_frame_parent,
    ),
    Builtin::new(
        "get_children",
        D,
        &[req("name")],
        "The names of frame `name`'s immediate children.",
        get_children,
    ),
    Builtin::new(
        "frame_tracking_enable",
        D,
        &[req("frame_name")],
        "Records frame `frame_name` as tracked (frames here move only by move_frame or with the arm).",
        frame_tracking_enable,
    ),
    Builtin::new(
        "frame_tracking_disable",
        D,
        &[],
        "Ends frame tracking.",
        frame_tracking_disable,
    ),
    Builtin::new(
        "set_mass_properties",
        D,
        &[req("frame"), req("m"), req("cog"), req("inertia")],
        "Sets an added frame's mass (kg), CoG (m, frame axes) and inertia [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the CoG.",
        set_mass_properties,
    ),
    Builtin::new(
        "set_payload_from_attached_frames",
        D,
        &[],
        "Sets the payload from the mass properties of the frames under the flange.",
        set_payload_from_attached_frames,
    ),
];

fn now(c: &Runtime) -> ArmNow {
    ArmNow {
        flange: c.flange_pose(),
        tcp: c.arm.tcp,
    }
}

fn fail(a: &Args, e: String) -> Fault {
    Fault::from(format!("`{}`: {e}", a.name))
}

fn done(r: Result<(), String>, a: &Args) -> Result<Out, Fault> {
    r.map(|()| Out::Value(Value::None)).map_err(|e| fail(a, e))
}

fn add_frame(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (name, p, reference) = (a.text(0)?, a.six(1)?, a.text(2)?);
    let arm = now(c);
    done(c.arm.world_model.add(&name, p, &reference, arm), a)
}

fn attach_frame(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (child, parent) = (a.text(0)?, a.text(1)?);
    let arm = now(c);
    done(c.arm.world_model.attach(&child, &parent, arm), a)
}

fn delete_frame(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    let arm = now(c);
    done(c.arm.world_model.delete(&name, arm), a)
}

fn delete_all_frames(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.delete_all(arm), a)
}

fn move_frame(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (name, p, reference) = (a.text(0)?, a.six(1)?, a.text(2)?);
    let arm = now(c);
    done(c.arm.world_model.move_to(&name, p, &reference, arm), a)
}

fn get_pose(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (name, rel) = (a.text(0)?, a.text(1)?);
    let reference = if a.is_absent(2) {
        rel.clone()
    } else {
        a.text(2)?
    };
    c.arm
        .world_model
        .get_pose(&name, &rel, &reference, now(c))
        .map(|p| Out::Value(Value::Pose(p)))
        .map_err(|e| fail(a, e))
}

fn convert_pose(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (p, from, to) = (a.six(0)?, a.text(1)?, a.text(2)?);
    c.arm
        .world_model
        .convert(p, &from, &to, now(c))
        .map(|p| Out::Value(Value::Pose(p)))
        .map_err(|e| fail(a, e))
}

fn reset_world_model(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.arm.world_model.reset();
    Ok(Out::Value(Value::None))
}

fn is_frame(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    Ok(Out::Value(Value::Bool(c.arm.world_model.is_frame(&name))))
}

fn get_frame_parent(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    c.arm
        .world_model
        .parent(&name)
        .map(|p| Out::Value(Value::Str(p.into_bytes())))
        .map_err(|e| fail(a, e))
}

fn get_children(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    c.arm
        .world_model
        .get_children(&name)
        .map(|v| {
            Out::Value(Value::List(
                v.into_iter().map(|n| Value::Str(n.into_bytes())).collect(),
            ))
        })
        .map_err(|e| fail(a, e))
}

fn frame_tracking_enable(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let name = a.text(0)?;
    done(c.arm.world_model.track(Some(&name)), a)
}

fn frame_tracking_disable(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    done(c.arm.world_model.track(None), a)
}

fn set_mass_properties(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (frame, m) = (a.text(0)?, a.num(1)?);
    let cog: [f64; 3] = a.nums(2)?;
    let inertia: [f64; 6] = a.nums(3)?;
    done(c.arm.world_model.set_mass(&frame, m, cog, inertia), a)
}

fn set_payload_from_attached_frames(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (m, cog, inertia) = c.arm.world_model.payload(now(c)).map_err(|e| fail(a, e))?;
    c.arm.payload_mass = m;
    c.arm.payload_cog = cog;
    c.arm.payload_inertia = inertia;
    Ok(Out::Value(Value::None))
}
