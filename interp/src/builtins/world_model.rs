//! The world model functions (UR's World Model API for PolyScope 5.x, with MotionPlus):
//! named frames on the virtual controller, kept by the arm across programs. The model,
//! its choices and bounds are in [`crate::world_model`].

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;
use crate::world_model::ArmNow;

const D: Domain = Domain::Poses;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        add_frame(name: String, pose: [f64; 6], ref_frame: String = Str("base")) => add_frame,
        "Adds frame `name` at `pose` given in `ref_frame`, under world.",
    ),
    builtin!(
        attach_frame(child: String, parent: String) => attach_frame,
        "Attaches frame `child` to `parent`, keeping its place in the world.",
    ),
    builtin!(
        delete_frame(name: String) => delete_frame,
        "Deletes an added frame; its children stay where they are, under world.",
    ),
    builtin!(
        delete_all_frames() => delete_all_frames,
        "Deletes every added frame (world, base, flange and tcp stay).",
    ),
    builtin!(
        move_frame(name: String, pose: [f64; 6], ref_frame: String = Str("base")) => move_frame,
        "Moves frame `name` (its children with it) to `pose` given in `ref_frame`.",
    ),
    builtin!(
        get_pose(name: String, rel_frame: String, ref_frame: Option<String> = Absent) => get_pose,
        "The pose of frame `name` relative to `rel_frame`, in `ref_frame`'s axes (default: rel_frame's).",
    ),
    builtin!(
        convert_pose(pose: [f64; 6], from_frame: String, to_frame: String) => convert_pose,
        "A pose given in `from_frame`, given in `to_frame`.",
    ),
    builtin!(
        reset_world_model() => reset_world_model,
        "Deletes every added frame and puts base back at the world origin.",
    ),
    builtin!(
        is_frame(name: String) => is_frame,
        "True if the world model has a frame `name`.",
    ),
    builtin!(
        get_frame_parent(name: String) => get_frame_parent,
        "The name of frame `name`'s parent.",
    ),
    builtin!(
        get_children(name: String) => get_children,
        "The names of frame `name`'s immediate children.",
    ),
    builtin!(
        frame_tracking_enable(frame_name: String) => frame_tracking_enable,
        "Records frame `frame_name` as tracked (frames here move only by move_frame or with the arm).",
    ),
    builtin!(
        frame_tracking_disable() => frame_tracking_disable,
        "Ends frame tracking.",
    ),
    builtin!(
        set_mass_properties(frame: String, m: f64, cog: [f64; 3], inertia: [f64; 6]) => set_mass_properties,
        "Sets an added frame's mass (kg), CoG (m, frame axes) and inertia [Ixx, Iyy, Izz, Ixy, Ixz, Iyz] about the CoG.",
    ),
    builtin!(
        set_payload_from_attached_frames() => set_payload_from_attached_frames,
        "Sets the payload from the mass properties of the frames under the flange.",
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

fn add_frame(
    c: &mut Runtime,
    a: &mut Args,
    name: String,
    p: [f64; 6],
    reference: String,
) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.add(&name, p, &reference, arm), a)
}

fn attach_frame(
    c: &mut Runtime,
    a: &mut Args,
    child: String,
    parent: String,
) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.attach(&child, &parent, arm), a)
}

fn delete_frame(c: &mut Runtime, a: &mut Args, name: String) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.delete(&name, arm), a)
}

fn delete_all_frames(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.delete_all(arm), a)
}

fn move_frame(
    c: &mut Runtime,
    a: &mut Args,
    name: String,
    p: [f64; 6],
    reference: String,
) -> Result<Out, Fault> {
    let arm = now(c);
    done(c.arm.world_model.move_to(&name, p, &reference, arm), a)
}

fn get_pose(
    c: &mut Runtime,
    a: &mut Args,
    name: String,
    rel: String,
    reference: Option<String>,
) -> Result<Out, Fault> {
    let reference = reference.unwrap_or_else(|| rel.clone());
    c.arm
        .world_model
        .get_pose(&name, &rel, &reference, now(c))
        .map(|p| Out::Value(Value::Pose(p)))
        .map_err(|e| fail(a, e))
}

fn convert_pose(
    c: &mut Runtime,
    a: &mut Args,
    p: [f64; 6],
    from: String,
    to: String,
) -> Result<Out, Fault> {
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

fn is_frame(c: &mut Runtime, _: &mut Args, name: String) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(c.arm.world_model.is_frame(&name))))
}

fn get_frame_parent(c: &mut Runtime, a: &mut Args, name: String) -> Result<Out, Fault> {
    c.arm
        .world_model
        .parent(&name)
        .map(|p| Out::Value(Value::Str(p.into_bytes())))
        .map_err(|e| fail(a, e))
}

fn get_children(c: &mut Runtime, a: &mut Args, name: String) -> Result<Out, Fault> {
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

fn frame_tracking_enable(c: &mut Runtime, a: &mut Args, name: String) -> Result<Out, Fault> {
    done(c.arm.world_model.track(Some(&name)), a)
}

fn frame_tracking_disable(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    done(c.arm.world_model.track(None), a)
}

fn set_mass_properties(
    c: &mut Runtime,
    a: &mut Args,
    frame: String,
    m: f64,
    cog: [f64; 3],
    inertia: [f64; 6],
) -> Result<Out, Fault> {
    done(c.arm.world_model.set_mass(&frame, m, cog, inertia), a)
}

fn set_payload_from_attached_frames(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (m, cog, inertia) = c.arm.world_model.payload(now(c)).map_err(|e| fail(a, e))?;
    c.arm.payload_mass = m;
    c.arm.payload_cog = cog;
    c.arm.payload_inertia = inertia;
    Ok(Out::Value(Value::None))
}
