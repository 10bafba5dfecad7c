//! Setting the world from a command line or a test: `NAME=VALUE` and `NAME[I]=VALUE`
//! (`ursock robot --set digital_in[3]=True`), where NAME is a field of [`World`] and
//! VALUE a URScript constant (`True`, `4.2`, `[0, 0, -10, 0, 0, 0]`, `"ok"`).

use crate::runtime::{Arm, World};
use crate::value::Value;

/// Why a setting was refused: the setting as given and what is wrong with it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SetError {
    setting: String,
    reason: String,
}

impl SetError {
    fn new(setting: &str, reason: impl Into<String>) -> Self {
        SetError {
            setting: setting.to_string(),
            reason: reason.into(),
        }
    }

    /// What is wrong (without the setting).
    pub fn reason(&self) -> &str {
        &self.reason
    }
}

impl core::fmt::Display for SetError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{}: {}", self.setting, self.reason)
    }
}

impl core::error::Error for SetError {}

/// The names [`World::set`] knows, with what each holds, for a CLI's help.
pub const WORLD_SETTINGS: &[(&str, &str)] = &[
    (
        "digital_in",
        "18 bools: standard 0-7, configurable 8-15, tool 16-17",
    ),
    ("analog_in", "4 floats: standard 0-1, tool 2-3"),
    ("input_int_regs", "48 ints: RTDE input int registers"),
    ("input_float_regs", "48 floats: RTDE input float registers"),
    ("input_bool_regs", "128 bools: RTDE input bool registers"),
    (
        "tcp_force",
        "6 floats: force (N) and torque (Nm) at the tool",
    ),
    (
        "contact_plane",
        "pose p[x, y, z, rx, ry, rz] (or 6 floats): a surface the tool touches, its z axis the outward normal",
    ),
    (
        "contact_stiffness",
        "float: the contact plane's stiffness (N/m; 0: no surface)",
    ),
    ("joint_torques", "6 floats: external joint torques (Nm)"),
    ("joint_temp", "6 floats: joint temperatures (°C)"),
    ("controller_temp", "float: control box temperature (°C)"),
    ("tool_temp", "float: tool temperature (°C)"),
    ("tool_current", "float: tool current (A)"),
    (
        "operator_bool",
        "bool: the answer to request_boolean_from_primary_client",
    ),
    (
        "operator_int",
        "int: the answer to request_integer_from_primary_client",
    ),
    (
        "operator_float",
        "float: the answer to request_float_from_primary_client",
    ),
    (
        "operator_string",
        "string: the answer to request_string_from_primary_client",
    ),
    (
        "controller_uptime",
        "seconds: how long the controller ran before the program (time(0))",
    ),
    (
        "system_time",
        "seconds since 1970-01-01 GMT when the program starts (time(2))",
    ),
    (
        "eip_from_plc",
        "eip_from_plc[ID]=[bytes 0-255]: what the EtherNet/IP scanner sent on PLC->Robot instance ID",
    ),
    ("euromap_in", "32 bools: Euromap67 input signals"),
    (
        "rtde_watchdogs",
        "bool: rtde_set_watchdog's watchdogs act (no RTDE client writes inputs here, so they fire)",
    ),
    (
        "eip_connected",
        "bool: an EtherNet/IP scanner is connected (feeds watchdogs; is_instance_connected)",
    ),
];

impl World {
    /// Sets one field from `NAME=VALUE` (a whole field: a list for the arrays) or
    /// `NAME[I]=VALUE` (one element). NAME is a field of this struct (see
    /// [`WORLD_SETTINGS`]); VALUE a URScript constant of the field's type (an int is a
    /// float where a float is wanted; a bool is not a number here).
    ///
    /// ```
    /// use urscript_interp::World;
    /// let mut w = World::default();
    /// w.set("digital_in[3]=True").unwrap();
    /// w.set("tcp_force=[0, 0, -9.8, 0, 0, 0]").unwrap();
    /// assert!(w.digital_in[3]);
    /// assert_eq!(w.tcp_force[2], -9.8);
    /// assert_eq!(
    ///     w.set("digital_in[18]=True").unwrap_err().to_string(),
    ///     "digital_in[18]=True: index 18 is past the last (17)"
    /// );
    /// ```
    pub fn set(&mut self, setting: &str) -> Result<(), SetError> {
        let err = |reason: String| SetError::new(setting, reason);
        let (name, index, value) = parse(setting)?;
        let slot = |len: usize| -> Result<Option<usize>, SetError> {
            match index {
                Some(i) if i >= len => Err(err(format!(
                    "index {i} is past the last ({})",
                    len.saturating_sub(1)
                ))),
                other => Ok(other),
            }
        };
        let scalar_only = || -> Result<(), SetError> {
            match index {
                Some(_) => Err(err(format!("`{name}` is one value: give it without [ ]"))),
                None => Ok(()),
            }
        };
        match name {
            "digital_in" => fill(&mut self.digital_in, slot(18)?, &value, as_bool),
            "analog_in" => fill(&mut self.analog_in, slot(4)?, &value, as_float),
            "input_int_regs" => fill(&mut self.input_int_regs, slot(48)?, &value, as_int),
            "input_float_regs" => fill(&mut self.input_float_regs, slot(48)?, &value, as_float),
            "input_bool_regs" => fill(&mut self.input_bool_regs, slot(128)?, &value, as_bool),
            "tcp_force" => fill(&mut self.tcp_force, slot(6)?, &value, as_float),
            "contact_plane" => match (&value, index) {
                (Value::Pose(p), None) if p.iter().all(|x| x.is_finite()) => {
                    self.contact_plane = *p;
                    Ok(())
                }
                _ => fill(&mut self.contact_plane, slot(6)?, &value, as_float),
            }
            .map_err(|_| "a pose p[x, y, z, rx, ry, rz] (m, rad) or a list of 6".to_string()),
            "contact_stiffness" => {
                scalar_only()?;
                match as_float(&value) {
                    Ok(k) if k >= 0.0 && k.is_finite() => {
                        self.contact_stiffness = k;
                        Ok(())
                    }
                    _ => Err("a stiffness in N/m, 0 or more".to_string()),
                }
            }
            "joint_torques" => fill(&mut self.joint_torques, slot(6)?, &value, as_float),
            "joint_temp" => fill(&mut self.joint_temp, slot(6)?, &value, as_float),
            "controller_temp" => {
                scalar_only()?;
                as_float(&value).map(|v| self.controller_temp = v)
            }
            "tool_temp" => {
                scalar_only()?;
                as_float(&value).map(|v| self.tool_temp = v)
            }
            "tool_current" => {
                scalar_only()?;
                as_float(&value).map(|v| self.tool_current = v)
            }
            "operator_bool" => {
                scalar_only()?;
                as_bool(&value).map(|v| self.operator_bool = v)
            }
            "operator_int" => {
                scalar_only()?;
                as_int(&value).map(|v| self.operator_int = v)
            }
            "operator_float" => {
                scalar_only()?;
                as_float(&value).map(|v| self.operator_float = v)
            }
            "operator_string" => {
                scalar_only()?;
                match value {
                    Value::Str(s) => {
                        self.operator_string = s;
                        Ok(())
                    }
                    _ => Err("a string".to_string()),
                }
            }
            "controller_uptime" => {
                scalar_only()?;
                as_seconds(&value).map(|v| self.controller_uptime = v)
            }
            "system_time" => {
                scalar_only()?;
                as_seconds(&value).map(|v| self.system_time = v)
            }
            "euromap_in" => fill(&mut self.euromap_in, slot(32)?, &value, as_bool),
            "rtde_watchdogs" => {
                scalar_only()?;
                as_bool(&value).map(|v| self.rtde_watchdogs = v)
            }
            "eip_connected" => {
                scalar_only()?;
                as_bool(&value).map(|v| self.eip_connected = v)
            }
            "eip_from_plc" => {
                let Some(id) = index.and_then(|i| i32::try_from(i).ok()) else {
                    return Err(err("give the instance: eip_from_plc[ID]=[...]".into()));
                };
                let Value::List(items) = &value else {
                    return Err(err("`eip_from_plc` takes a list of bytes (0-255)".into()));
                };
                if items.len() > crate::eip::MAX_DATA_SIZE {
                    return Err(err(format!("at most {} bytes", crate::eip::MAX_DATA_SIZE)));
                }
                if !self.eip_from_plc.contains_key(&id)
                    && self.eip_from_plc.len() >= crate::eip::MAX_INSTANCES
                {
                    return Err(err(format!(
                        "at most {} instances",
                        crate::eip::MAX_INSTANCES
                    )));
                }
                let bytes: Option<Vec<u8>> = items
                    .iter()
                    .map(|v| match v {
                        Value::Int(b) => u8::try_from(*b).ok(),
                        _ => None,
                    })
                    .collect();
                match bytes {
                    Some(b) => {
                        self.eip_from_plc.insert(id, b);
                        Ok(())
                    }
                    None => Err("a list of bytes (ints 0-255)".to_string()),
                }
            }
            _ => {
                let known: Vec<&str> = WORLD_SETTINGS.iter().map(|(n, _)| *n).collect();
                return Err(err(format!(
                    "`{name}` is not a setting of the world (known: {})",
                    known.join(", ")
                )));
            }
        }
        .map_err(|wanted| err(format!("`{name}` takes {wanted}")))
    }
}

/// `NAME=VALUE` or `NAME[I]=VALUE`: the name, the index, the value.
fn parse(setting: &str) -> Result<(&str, Option<usize>, Value), SetError> {
    let err = |reason: String| SetError::new(setting, reason);
    let (target, text) = setting
        .split_once('=')
        .ok_or_else(|| err("give NAME=VALUE or NAME[INDEX]=VALUE".into()))?;
    let target = target.trim();
    let (name, index) = match target.split_once('[') {
        Some((name, rest)) => {
            let i = rest
                .strip_suffix(']')
                .and_then(|i| i.trim().parse::<usize>().ok())
                .ok_or_else(|| err(format!("`{target}`: the index is not a number in [ ]")))?;
            (name.trim(), Some(i))
        }
        None => (target, None),
    };
    let value = crate::parse_constant(text.trim())
        .map_err(|e| err(format!("`{}` is not a URScript constant: {e}", text.trim())))?;
    Ok((name, index, value))
}

/// The names [`Arm::set`] knows besides the world's ([`WORLD_SETTINGS`]).
pub const ARM_SETTINGS: &[(&str, &str)] = &[(
    "q",
    "6 floats: the joint positions at the start (rad, each within ±2π)",
)];

impl Arm {
    /// Sets the arm's joints from `q=[...]` or `q[I]=VALUE` (rad, each within ±2π, the
    /// joints' range), or anything of its world ([`World::set`]): the arm a program
    /// starts with (`Machine::with_arm`).
    ///
    /// ```
    /// use urscript_interp::Arm;
    /// let mut arm = Arm::default();
    /// arm.set("q=[0, -1.2, 1.5, -1.9, -1.57, 0]").unwrap();
    /// arm.set("digital_in[1]=True").unwrap();
    /// assert_eq!(arm.q[1], -1.2);
    /// assert!(arm.world.digital_in[1]);
    /// assert!(arm.set("q[0]=7").is_err());
    /// ```
    pub fn set(&mut self, setting: &str) -> Result<(), SetError> {
        let (name, index, value) = parse(setting)?;
        if name != "q" {
            return self.world.set(setting);
        }
        let err = |reason: String| SetError::new(setting, reason);
        if let Some(i) = index.filter(|i| *i >= 6) {
            return Err(err(format!("index {i} is past the last (5)")));
        }
        let mut q = self.q;
        fill(&mut q, index, &value, as_float).map_err(|w| err(format!("`q` takes {w}")))?;
        let limit = 2.0 * core::f64::consts::PI;
        if let Some((k, v)) = q
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || v.abs() > limit)
        {
            return Err(err(format!(
                "joint {k} at {v} rad is outside the joints' range (±2π)"
            )));
        }
        self.q = q;
        Ok(())
    }
}

/// Sets element `index` of `field`, or the whole field from a list of its length.
fn fill<T: Copy, const N: usize>(
    field: &mut [T; N],
    index: Option<usize>,
    value: &Value,
    conv: fn(&Value) -> Result<T, String>,
) -> Result<(), String> {
    match index {
        Some(i) => {
            let v = conv(value)?;
            if let Some(slot) = field.get_mut(i) {
                *slot = v;
            }
            Ok(())
        }
        None => {
            let Value::List(items) = value else {
                return Err(format!("a list of {N} (or give [INDEX] for one)"));
            };
            if items.len() != N {
                return Err(format!("a list of {N}, not {}", items.len()));
            }
            let mut out = *field;
            for (slot, item) in out.iter_mut().zip(items) {
                *slot = conv(item)?;
            }
            *field = out;
            Ok(())
        }
    }
}

fn as_bool(v: &Value) -> Result<bool, String> {
    match v {
        Value::Bool(b) => Ok(*b),
        _ => Err("True or False".into()),
    }
}

fn as_int(v: &Value) -> Result<i32, String> {
    match v {
        Value::Int(i) => Ok(*i),
        _ => Err("an int".into()),
    }
}

fn as_float(v: &Value) -> Result<f64, String> {
    match v {
        Value::Int(i) => Ok(f64::from(*i)),
        Value::Float(f) => Ok(*f),
        _ => Err("a number".into()),
    }
}

/// A number of seconds, 0 or more (a float keeps about 0.2 µs at 10⁹ s).
fn as_seconds(v: &Value) -> Result<std::time::Duration, String> {
    let wanted = || "a number of seconds, 0 or more".to_string();
    let s = as_float(v).map_err(|_| wanted())?;
    if s < 0.0 {
        return Err(wanted());
    }
    std::time::Duration::try_from_secs_f64(s).map_err(|_| wanted())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_setting_is_known() {
        for (name, _) in WORLD_SETTINGS {
            let e = World::default().set(&format!("{name}=\"not this\""));
            // Known names fail on the value's type (or succeed for the string), never
            // as an unknown name.
            if let Err(e) = e {
                assert!(!e.reason().contains("not a setting"), "{name}: {e}");
            }
        }
    }

    #[test]
    fn clocks_take_seconds() {
        let mut w = World::default();
        w.set("system_time=1700000000").unwrap();
        w.set("controller_uptime=12.5").unwrap();
        assert_eq!(w.system_time, std::time::Duration::from_secs(1_700_000_000));
        assert_eq!(
            w.controller_uptime,
            std::time::Duration::from_millis(12_500)
        );
        for bad in [
            "system_time=-1",
            "system_time=1e300",
            "controller_uptime=True",
        ] {
            let e = w.set(bad).unwrap_err();
            assert!(e.reason().contains("a number of seconds, 0 or more"), "{e}");
        }
        assert!(w.set("system_time[0]=1").is_err());
    }

    #[test]
    fn elements_lists_and_scalars() {
        let mut w = World::default();
        w.set("analog_in[1] = 4").unwrap();
        w.set("input_int_regs[47]=-7").unwrap();
        w.set("joint_temp=[40, 41, 42, 43, 44, 45.5]").unwrap();
        w.set("controller_temp=50.5").unwrap();
        w.set("operator_string=\"yes\"").unwrap();
        assert_eq!(w.analog_in[1], 4.0);
        assert_eq!(w.input_int_regs[47], -7);
        assert_eq!(w.joint_temp, [40.0, 41.0, 42.0, 43.0, 44.0, 45.5]);
        assert_eq!(w.controller_temp, 50.5);
        assert_eq!(w.operator_string, b"yes");
    }

    #[test]
    fn refusals_name_what_is_wrong_and_change_nothing() {
        let mut w = World::default();
        for (setting, reason) in [
            ("digital_in", "give NAME=VALUE or NAME[INDEX]=VALUE"),
            (
                "digital_in[x]=True",
                "`digital_in[x]`: the index is not a number in [ ]",
            ),
            ("digital_in[2]=1", "`digital_in` takes True or False"),
            ("input_int_regs[0]=1.5", "`input_int_regs` takes an int"),
            ("joint_temp=[1, 2]", "`joint_temp` takes a list of 6, not 2"),
            (
                "joint_temp=[1, 2, 3, 4, 5, True]",
                "`joint_temp` takes a number",
            ),
            (
                "tool_temp[0]=3",
                "`tool_temp` is one value: give it without [ ]",
            ),
            (
                "tcp_force=3",
                "`tcp_force` takes a list of 6 (or give [INDEX] for one)",
            ),
        ] {
            assert_eq!(w.set(setting).unwrap_err().reason(), reason, "{setting}");
        }
        assert!(w
            .set("gripper=1")
            .unwrap_err()
            .reason()
            .starts_with("`gripper` is not a setting of the world (known: digital_in,"));
        assert!(w
            .set("tool_temp=(")
            .unwrap_err()
            .reason()
            .starts_with("`(` is not a URScript constant"));
        assert_eq!(w, World::default());
    }
}
