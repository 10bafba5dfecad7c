//! The controller's state and its timed transitions, with time as an input.
//!
//! Every operation takes `now` (a [`Duration`] since any fixed origin the caller picks)
//! and first settles every transition whose moment has come, so the state a caller reads
//! right after an operation is the state at `now`. [`Controller::poll_timeout`] says when
//! the next timed transition is due, as quinn-proto's `poll_timeout` does.

use std::collections::VecDeque;
use std::fmt;
use std::time::Duration;

use urscript_interp::kinematics::Model;

/// The robot mode, as the e-Series controller names it (`robotmode`, RTDE `robot_mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RobotMode {
    /// No controller (-1).
    NoController,
    /// The controller is not connected to the arm (0).
    Disconnected,
    /// The safety configuration waits for confirmation (1).
    ConfirmSafety,
    /// The arm's joints are booting after `power on` (2).
    Booting,
    /// Arm power is off (3).
    PowerOff,
    /// Arm power is on, the joints are starting (4).
    PowerOn,
    /// Powered, brakes engaged (5).
    Idle,
    /// Backdrive mode (6).
    Backdrive,
    /// Powered, brakes released: ready to move (7).
    Running,
    /// Joint firmware is being updated (8).
    UpdatingFirmware,
}

impl RobotMode {
    /// The name the dashboard prints (`IDLE`).
    pub fn name(self) -> &'static str {
        match self {
            RobotMode::NoController => "NO_CONTROLLER",
            RobotMode::Disconnected => "DISCONNECTED",
            RobotMode::ConfirmSafety => "CONFIRM_SAFETY",
            RobotMode::Booting => "BOOTING",
            RobotMode::PowerOff => "POWER_OFF",
            RobotMode::PowerOn => "POWER_ON",
            RobotMode::Idle => "IDLE",
            RobotMode::Backdrive => "BACKDRIVE",
            RobotMode::Running => "RUNNING",
            RobotMode::UpdatingFirmware => "UPDATING_FIRMWARE",
        }
    }

    /// The number RTDE and the primary interface carry (`robot_mode`).
    pub fn code(self) -> i32 {
        match self {
            RobotMode::NoController => -1,
            RobotMode::Disconnected => 0,
            RobotMode::ConfirmSafety => 1,
            RobotMode::Booting => 2,
            RobotMode::PowerOff => 3,
            RobotMode::PowerOn => 4,
            RobotMode::Idle => 5,
            RobotMode::Backdrive => 6,
            RobotMode::Running => 7,
            RobotMode::UpdatingFirmware => 8,
        }
    }
}

impl fmt::Display for RobotMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The safety status (`safetystatus`, RTDE `safety_status`). The older `safetymode`
/// reply is derived from it ([`SafetyStatus::safety_mode_name`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SafetyStatus {
    /// Normal operation (1).
    Normal,
    /// Reduced mode (2).
    Reduced,
    /// A protective stop (3): the arm stopped, program paused; `unlock protective stop`
    /// after [`Timing::protective_stop_hold`].
    ProtectiveStop,
    /// Recovery mode (4).
    Recovery,
    /// A safeguard stop input (5).
    SafeguardStop,
    /// The system emergency stop input (6).
    SystemEmergencyStop,
    /// The robot's emergency stop button (7).
    RobotEmergencyStop,
    /// A safety limit violation (8): `restart safety` to recover.
    Violation,
    /// A safety fault (9): `restart safety` to recover.
    Fault,
    /// The automatic-mode safeguard stop input (12).
    AutomaticModeSafeguardStop,
    /// The three-position enabling device released (13).
    SystemThreePositionEnablingStop,
}

impl SafetyStatus {
    /// The name `safetystatus` prints.
    pub fn name(self) -> &'static str {
        match self {
            SafetyStatus::Normal => "NORMAL",
            SafetyStatus::Reduced => "REDUCED",
            SafetyStatus::ProtectiveStop => "PROTECTIVE_STOP",
            SafetyStatus::Recovery => "RECOVERY",
            SafetyStatus::SafeguardStop => "SAFEGUARD_STOP",
            SafetyStatus::SystemEmergencyStop => "SYSTEM_EMERGENCY_STOP",
            SafetyStatus::RobotEmergencyStop => "ROBOT_EMERGENCY_STOP",
            SafetyStatus::Violation => "VIOLATION",
            SafetyStatus::Fault => "FAULT",
            SafetyStatus::AutomaticModeSafeguardStop => "AUTOMATIC_MODE_SAFEGUARD_STOP",
            SafetyStatus::SystemThreePositionEnablingStop => "SYSTEM_THREE_POSITION_ENABLING_STOP",
        }
    }

    /// The name the older `safetymode` prints: the two e-Series stops it predates are
    /// reported as `SAFEGUARD_STOP`, as RTDE's `safety_mode` does.
    pub fn safety_mode_name(self) -> &'static str {
        match self {
            SafetyStatus::AutomaticModeSafeguardStop
            | SafetyStatus::SystemThreePositionEnablingStop => "SAFEGUARD_STOP",
            s => s.name(),
        }
    }

    /// The number RTDE carries (`safety_status`).
    pub fn code(self) -> i32 {
        match self {
            SafetyStatus::Normal => 1,
            SafetyStatus::Reduced => 2,
            SafetyStatus::ProtectiveStop => 3,
            SafetyStatus::Recovery => 4,
            SafetyStatus::SafeguardStop => 5,
            SafetyStatus::SystemEmergencyStop => 6,
            SafetyStatus::RobotEmergencyStop => 7,
            SafetyStatus::Violation => 8,
            SafetyStatus::Fault => 9,
            SafetyStatus::AutomaticModeSafeguardStop => 12,
            SafetyStatus::SystemThreePositionEnablingStop => 13,
        }
    }

    /// Whether the arm may move (normal or reduced).
    pub fn allows_motion(self) -> bool {
        matches!(self, SafetyStatus::Normal | SafetyStatus::Reduced)
    }

    /// Whether arm power is cut: an emergency stop, a violation or a fault.
    pub fn cuts_power(self) -> bool {
        matches!(
            self,
            SafetyStatus::SystemEmergencyStop
                | SafetyStatus::RobotEmergencyStop
                | SafetyStatus::Violation
                | SafetyStatus::Fault
        )
    }
}

impl fmt::Display for SafetyStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The loaded program's execution state (`programState`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ProgramState {
    /// Not running.
    Stopped,
    /// Running (`play`).
    Playing,
    /// Paused (`pause`, or a protective stop while playing).
    Paused,
}

impl ProgramState {
    /// The name `programState` prints.
    pub fn name(self) -> &'static str {
        match self {
            ProgramState::Stopped => "STOPPED",
            ProgramState::Playing => "PLAYING",
            ProgramState::Paused => "PAUSED",
        }
    }
}

impl fmt::Display for ProgramState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The operational mode a dashboard client set (`set operational mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum OperationalMode {
    /// Programs and installations may be loaded and edited.
    Manual,
    /// Only playing programs.
    Automatic,
}

impl OperationalMode {
    /// The name `get operational mode` prints.
    pub fn name(self) -> &'static str {
        match self {
            OperationalMode::Manual => "MANUAL",
            OperationalMode::Automatic => "AUTOMATIC",
        }
    }

    /// `manual` / `automatic`, any case.
    pub fn parse(s: &str) -> Option<Self> {
        if s.eq_ignore_ascii_case("manual") {
            Some(OperationalMode::Manual)
        } else if s.eq_ignore_ascii_case("automatic") {
            Some(OperationalMode::Automatic)
        } else {
            None
        }
    }
}

/// How long the timed transitions take. The defaults are short (a simulator's, not a
/// real arm's, whose power-on takes several seconds) except the protective-stop hold,
/// which is the controller's documented 5 s. UR documents no times; the defaults take
/// the arm from POWER_OFF to RUNNING in 0.4 s (`brake release` alone, or `power on`
/// and `brake release` at once) because the clients UR tests against URSim expect it
/// there that fast: UR's client library's `dashboard_client_g5_tests`, in UR's CI order,
/// send a program 0.6 s after a `brake release` from POWER_OFF and want it to run (a
/// program sent before RUNNING is refused), and UR's ROS 2 driver's integration tests
/// (`start_robot`) wanted RUNNING 1 s after `power on` and `brake release`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// `power on`: time in BOOTING before POWER_ON.
    pub booting: Duration,
    /// `power on`: time in POWER_ON before IDLE.
    pub power_on: Duration,
    /// `brake release`: time from IDLE to RUNNING.
    pub brake_release: Duration,
    /// A protective stop can be unlocked this long after it happened (5 s).
    pub protective_stop_hold: Duration,
    /// `restart safety`: time in BOOTING before POWER_OFF with the safety NORMAL.
    pub restart_safety: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            booting: Duration::from_millis(100),
            power_on: Duration::from_millis(100),
            brake_release: Duration::from_millis(200),
            protective_stop_hold: Duration::from_secs(5),
            restart_safety: Duration::from_millis(500),
        }
    }
}

/// Where programs and installations are found: the controller asks, the caller answers
/// (a directory for `ursock controller --programs DIR`, a list in tests), so the state
/// machine itself never touches a file system.
pub trait Programs: Send {
    /// The path `get loaded program` shows for `name` as given to `load` (relative to the
    /// programs directory, or absolute inside it), or `None` when there is no such file.
    fn find(&self, name: &str) -> Option<String>;
}

/// A fixed list of program (and installation) names, relative to `/programs`.
#[derive(Debug, Clone, Default)]
pub struct ProgramList {
    names: Vec<String>,
}

impl ProgramList {
    /// The programs `names` (`"pick.urp"`, `"default.installation"`).
    pub fn new<I: IntoIterator<Item = S>, S: Into<String>>(names: I) -> Self {
        ProgramList {
            names: names.into_iter().map(Into::into).collect(),
        }
    }
}

impl Programs for ProgramList {
    fn find(&self, name: &str) -> Option<String> {
        let relative = name.strip_prefix("/programs/").unwrap_or(name);
        self.names
            .iter()
            .find(|n| n.as_str() == relative)
            .map(|n| format!("/programs/{n}"))
    }
}

/// The controller's configuration: what it says about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Config {
    /// The arm model (`get robot model`).
    pub model: Model,
    /// The PolyScope version, `5.21.0` or with its build number `5.21.0.1234567`; a
    /// version of three parts is completed with `.0` where four are printed.
    pub polyscope: String,
    /// The build date `PolyscopeVersion` prints in parentheses.
    pub build_date: String,
    /// The serial number (`get serial number`; UR's begin with the year, `20`).
    pub serial: String,
    /// Whether the pendant is in remote control (the default: clients drive it).
    pub remote_control: bool,
    /// Whether the remote control setting is on (the default). Off, as on a new robot
    /// and on URSim, there is no local/remote switch: every command is accepted and
    /// `is in remote control` answers false (UR's dashboard page: false when remote
    /// control is disabled or the pendant is in local control).
    pub remote_control_enabled: bool,
    /// The durations of the timed transitions.
    pub timing: Timing,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            model: Model::Ur5e,
            polyscope: "5.23.0".into(),
            build_date: "Jan 01 2025".into(),
            serial: "20235500001".into(),
            remote_control: true,
            remote_control_enabled: true,
            timing: Timing::default(),
        }
    }
}

impl Config {
    /// The version with four parts (`5.21.0.0`).
    pub fn full_version(&self) -> String {
        let parts = self.polyscope.split('.').count();
        if parts >= 4 {
            self.polyscope.clone()
        } else {
            let mut v = self.polyscope.clone();
            for _ in parts..4 {
                v.push_str(".0");
            }
            v
        }
    }

    /// Whether the controller has interpreter mode and its socket (30020): PolyScope 5.10
    /// and later (UR's "Interpreter mode" article: "SW versions: 5.10 above", "e-Series
    /// only").
    ///
    /// ```
    /// use urscript_controller::Config;
    /// let at = |v: &str| Config { polyscope: v.into(), ..Config::default() }.has_interpreter_mode();
    /// assert!(at("5.10.0") && at("5.21.0.1234567"));
    /// assert!(!at("5.9.4") && !at("3.15.8"));
    /// ```
    pub fn has_interpreter_mode(&self) -> bool {
        let mut parts = self.polyscope.split('.').map(|p| p.parse::<u32>().ok());
        let major = parts.next().flatten().unwrap_or(0);
        let minor = parts.next().flatten().unwrap_or(0);
        (major, minor) >= (5, 10)
    }

    /// The major version: 5 for e-Series, 3 for CB3.
    pub fn major(&self) -> u32 {
        self.polyscope
            .split('.')
            .next()
            .and_then(|m| m.parse().ok())
            .unwrap_or(5)
    }
}

/// Why an operation was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// The pendant is in local control.
    LocalControl,
    /// The state does not allow it (no program, not RUNNING, a stop, ...).
    NotNow,
    /// `unlock protective stop` before the hold time passed.
    TooEarly,
    /// No such program or installation.
    NotFound,
}

/// Whether `name` ends in `ext` (any case): only `.urp` files load as programs and
/// `.installation` files as installations.
fn has_extension(name: &str, ext: &str) -> bool {
    name.len() > ext.len()
        && name
            .get(name.len() - ext.len()..)
            .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// The most `addToLog` messages kept (the oldest go first).
pub const MAX_LOG: usize = 256;

/// A timed transition pending, and when it happens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// BOOTING -> POWER_ON at the time; then, if `release`, on to RUNNING.
    PowerOn { at: Duration, release: bool },
    /// POWER_ON -> IDLE; then, if `release`, brake release.
    Idle { at: Duration, release: bool },
    /// IDLE -> RUNNING.
    Running { at: Duration },
    /// Safety restart done: POWER_OFF, NORMAL.
    SafetyRestarted { at: Duration },
}

impl Pending {
    fn at(self) -> Duration {
        match self {
            Pending::PowerOn { at, .. }
            | Pending::Idle { at, .. }
            | Pending::Running { at }
            | Pending::SafetyRestarted { at } => at,
        }
    }
}

/// The virtual controller: robot mode, safety, the loaded program and its state,
/// operational mode, remote control, and what the controller says about itself. Every
/// interface (the dashboard now; primary, RTDE next) reads this one state.
pub struct Controller {
    config: Config,
    programs: Box<dyn Programs>,
    robot_mode: RobotMode,
    safety: SafetyStatus,
    /// When the current protective stop happened.
    protective_since: Option<Duration>,
    pending: Option<Pending>,
    program_state: ProgramState,
    /// The loaded program: the name as given to `load`, and the path shown.
    loaded: Option<(String, String)>,
    installation: String,
    operational_mode: Option<OperationalMode>,
    remote_control: bool,
    popup: Option<String>,
    log: VecDeque<String>,
    shut_down: bool,
    /// A program sent over the primary, secondary or realtime interface runs (or is
    /// paused): it is the controller's current program, with no file loaded.
    script: bool,
    /// Counts flight reports and support files, for their ids.
    reports: u32,
}

impl fmt::Debug for Controller {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Controller")
            .field("robot_mode", &self.robot_mode)
            .field("safety", &self.safety)
            .field("program_state", &self.program_state)
            .field("loaded", &self.loaded)
            .field("pending", &self.pending)
            .finish_non_exhaustive()
    }
}

impl Controller {
    /// A controller as after boot: POWER_OFF, safety NORMAL, nothing loaded, no
    /// program found anywhere (see [`Controller::with_programs`]).
    pub fn new(config: Config) -> Self {
        let remote_control = config.remote_control;
        Controller {
            config,
            programs: Box::new(ProgramList::default()),
            robot_mode: RobotMode::PowerOff,
            safety: SafetyStatus::Normal,
            protective_since: None,
            pending: None,
            program_state: ProgramState::Stopped,
            loaded: None,
            installation: "default.installation".into(),
            operational_mode: None,
            remote_control,
            popup: None,
            log: VecDeque::new(),
            shut_down: false,
            script: false,
            reports: 0,
        }
    }

    /// The same, finding programs in `programs`.
    pub fn with_programs(mut self, programs: Box<dyn Programs>) -> Self {
        self.programs = programs;
        self
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// When the next timed transition is due, if one is pending.
    pub fn poll_timeout(&self) -> Option<Duration> {
        self.pending.map(Pending::at)
    }

    /// Settle every transition due at or before `now`.
    pub fn handle_timeout(&mut self, now: Duration) {
        while let Some(p) = self.pending {
            if p.at() > now {
                return;
            }
            self.pending = None;
            let t = self.config.timing;
            match p {
                Pending::PowerOn { at, release } => {
                    self.robot_mode = RobotMode::PowerOn;
                    self.pending = Some(Pending::Idle {
                        at: at + t.power_on,
                        release,
                    });
                }
                Pending::Idle { at, release } => {
                    self.robot_mode = RobotMode::Idle;
                    if release {
                        self.pending = Some(Pending::Running {
                            at: at + t.brake_release,
                        });
                    }
                }
                Pending::Running { .. } => self.robot_mode = RobotMode::Running,
                Pending::SafetyRestarted { .. } => {
                    self.robot_mode = RobotMode::PowerOff;
                    self.safety = SafetyStatus::Normal;
                }
            }
        }
    }

    /// The robot mode at `now`.
    pub fn robot_mode(&mut self, now: Duration) -> RobotMode {
        self.handle_timeout(now);
        self.robot_mode
    }

    /// The safety status at `now`.
    pub fn safety_status(&mut self, now: Duration) -> SafetyStatus {
        self.handle_timeout(now);
        self.safety
    }

    /// The program state.
    pub fn program_state(&self) -> ProgramState {
        self.program_state
    }

    /// The loaded program: the name as given to `load` and the path shown.
    pub fn loaded_program(&self) -> Option<(&str, &str)> {
        self.loaded.as_ref().map(|(n, p)| (n.as_str(), p.as_str()))
    }

    /// The loaded installation.
    pub fn installation(&self) -> &str {
        &self.installation
    }

    /// The operational mode, `None` when no dashboard client controls it.
    pub fn operational_mode(&self) -> Option<OperationalMode> {
        self.operational_mode
    }

    /// Whether the pendant is in remote control: never with the remote control setting
    /// off ([`Config::remote_control_enabled`]).
    pub fn remote_control(&self) -> bool {
        self.config.remote_control_enabled && self.remote_control
    }

    /// Switch the pendant between remote (`true`) and local control.
    pub fn set_remote_control(&mut self, remote: bool) {
        self.remote_control = remote;
    }

    /// The popup shown on the pendant, if any.
    pub fn popup(&self) -> Option<&str> {
        self.popup.as_deref()
    }

    /// Show (`Some`) or close (`None`) the pendant's popup.
    pub fn set_popup(&mut self, text: Option<String>) {
        self.popup = text;
    }

    /// The log messages added (`addToLog`), oldest first, at most [`MAX_LOG`].
    pub fn log(&self) -> impl Iterator<Item = &str> {
        self.log.iter().map(String::as_str)
    }

    /// Add a message to the log.
    pub fn add_to_log(&mut self, text: String) {
        if self.log.len() == MAX_LOG {
            self.log.pop_front();
        }
        self.log.push_back(text);
    }

    /// Whether `shutdown` was accepted: the controller is off.
    pub fn is_shut_down(&self) -> bool {
        self.shut_down
    }

    fn remote(&self) -> Result<(), Refused> {
        if self.remote_control || !self.config.remote_control_enabled {
            Ok(())
        } else {
            Err(Refused::LocalControl)
        }
    }

    /// `power on`: POWER_OFF -> BOOTING -> POWER_ON -> IDLE. Already powered: nothing
    /// changes. Refused under an emergency stop, a violation or a fault (power stays
    /// off).
    pub fn power_on(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        self.start_power_on(now, false)
    }

    fn start_power_on(&mut self, now: Duration, release: bool) -> Result<(), Refused> {
        if self.safety.cuts_power() || matches!(self.pending, Some(Pending::SafetyRestarted { .. }))
        {
            return Err(Refused::NotNow);
        }
        if self.robot_mode == RobotMode::PowerOff {
            self.robot_mode = RobotMode::Booting;
            self.pending = Some(Pending::PowerOn {
                at: now + self.config.timing.booting,
                release,
            });
        } else if release {
            // Already on its way: release the brakes once IDLE.
            match &mut self.pending {
                Some(Pending::PowerOn { release: r, .. })
                | Some(Pending::Idle { release: r, .. }) => *r = true,
                _ => {}
            }
        }
        Ok(())
    }

    /// `power off`: POWER_OFF at once; a playing or paused program stops.
    pub fn power_off(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.powerdown(now);
        Ok(())
    }

    /// `brake release`: IDLE -> RUNNING after [`Timing::brake_release`]; from POWER_OFF
    /// the arm is powered on first. Refused while the safety does not allow motion.
    pub fn brake_release(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        if !self.safety.allows_motion() {
            return Err(Refused::NotNow);
        }
        match self.robot_mode {
            RobotMode::PowerOff | RobotMode::Booting | RobotMode::PowerOn => {
                self.start_power_on(now, true)
            }
            RobotMode::Idle => {
                if self.pending.is_none() {
                    self.pending = Some(Pending::Running {
                        at: now + self.config.timing.brake_release,
                    });
                }
                Ok(())
            }
            RobotMode::Running => Ok(()),
            _ => Err(Refused::NotNow),
        }
    }

    /// A protective stop happens (a collision, a limit, `protective_stop()`): the safety
    /// status is PROTECTIVE_STOP; the robot mode stays. A playing loaded program pauses; a
    /// playing program a client sent (primary, secondary, realtime) ends: STOPPED, as
    /// URSim ends it (UR's client library waits for its `PROGRAM_XXX_STOPPED` after
    /// sending `protective_stop()`, and UR's ROS 2 driver has its script sent again).
    pub fn protective_stop(&mut self, now: Duration) {
        self.handle_timeout(now);
        if self.safety.cuts_power() {
            return;
        }
        self.safety = SafetyStatus::ProtectiveStop;
        self.protective_since = Some(now);
        self.program_protective_stopped();
    }

    fn program_protective_stopped(&mut self) {
        if self.program_state == ProgramState::Playing {
            if self.script {
                self.program_state = ProgramState::Stopped;
                self.script = false;
            } else {
                self.program_state = ProgramState::Paused;
            }
        }
    }

    /// `unlock protective stop`: NORMAL again, at least [`Timing::protective_stop_hold`]
    /// after the stop. Without a protective stop there is nothing to unlock (Ok).
    pub fn unlock_protective_stop(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        if self.safety != SafetyStatus::ProtectiveStop {
            return Ok(());
        }
        let since = self.protective_since.unwrap_or(now);
        if now.saturating_sub(since) < self.config.timing.protective_stop_hold {
            return Err(Refused::TooEarly);
        }
        self.safety = SafetyStatus::Normal;
        self.protective_since = None;
        Ok(())
    }

    /// `set unlock protective stop` on the primary interface: the stop is released at
    /// once, without the dashboard's 5 s hold. UR documents the hold for the dashboard
    /// command only; UR's client library, whose tests UR runs against URSim, sends this
    /// command right after a stop and requires the stop gone within 5 s of sending it,
    /// which neither a refusal nor a release deferred to the end of the hold would give.
    pub fn request_unlock_protective_stop(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        if self.safety == SafetyStatus::ProtectiveStop {
            self.safety = SafetyStatus::Normal;
            self.protective_since = None;
        }
        Ok(())
    }

    /// A safety event that cuts arm power (an emergency stop, a violation, a fault) or
    /// another stop status: power off for the first kind, a playing program stops.
    pub fn safety_event(&mut self, now: Duration, status: SafetyStatus) {
        self.handle_timeout(now);
        self.safety = status;
        if status == SafetyStatus::ProtectiveStop {
            self.protective_since = Some(now);
            self.program_protective_stopped();
        }
        if status.cuts_power() {
            self.pending = None;
            self.robot_mode = RobotMode::PowerOff;
            self.program_state = ProgramState::Stopped;
            self.script = false;
        } else if !status.allows_motion() && self.program_state == ProgramState::Playing {
            self.program_state = ProgramState::Paused;
        }
    }

    /// An emergency stop is released (or a safeguard reset): NORMAL, power stays off.
    /// Violations and faults need [`Controller::restart_safety`].
    pub fn release_stop(&mut self, now: Duration) {
        self.handle_timeout(now);
        if !matches!(self.safety, SafetyStatus::Violation | SafetyStatus::Fault) {
            self.safety = SafetyStatus::Normal;
            self.protective_since = None;
        }
    }

    /// `restart safety`: the safety system reboots; after [`Timing::restart_safety`] the
    /// arm is POWER_OFF and the safety NORMAL.
    pub fn restart_safety(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        self.program_state = ProgramState::Stopped;
        self.script = false;
        self.robot_mode = RobotMode::Booting;
        self.protective_since = None;
        self.pending = Some(Pending::SafetyRestarted {
            at: now + self.config.timing.restart_safety,
        });
        Ok(())
    }

    /// `load NAME`: the program becomes the loaded one, STOPPED. Refused while a program
    /// plays or is paused, in AUTOMATIC operational mode (only playing is allowed
    /// there), for a file that is not a `.urp`, and when no such file exists.
    pub fn load(&mut self, name: &str) -> Result<(), Refused> {
        self.remote()?;
        let path = self.programs.find(name).ok_or(Refused::NotFound)?;
        if self.program_state != ProgramState::Stopped
            || self.operational_mode == Some(OperationalMode::Automatic)
            || !has_extension(name, ".urp")
        {
            return Err(Refused::NotNow);
        }
        self.loaded = Some((name.to_string(), path));
        Ok(())
    }

    /// `load installation NAME`.
    pub fn load_installation(&mut self, name: &str) -> Result<(), Refused> {
        self.remote()?;
        self.programs.find(name).ok_or(Refused::NotFound)?;
        if self.program_state != ProgramState::Stopped
            || self.operational_mode == Some(OperationalMode::Automatic)
            || !has_extension(name, ".installation")
        {
            return Err(Refused::NotNow);
        }
        self.installation = name.to_string();
        Ok(())
    }

    /// `play`: PLAYING, from STOPPED or PAUSED, when a program is loaded, the arm is
    /// RUNNING and the safety allows motion. (This step keeps only the state: the
    /// program's text is not executed.)
    pub fn play(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        let resumes_script = self.script && self.program_state == ProgramState::Paused;
        if (self.loaded.is_none() && !resumes_script)
            || self.robot_mode != RobotMode::Running
            || !self.safety.allows_motion()
        {
            return Err(Refused::NotNow);
        }
        self.program_state = ProgramState::Playing;
        Ok(())
    }

    /// `pause`: PLAYING -> PAUSED.
    pub fn pause(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        if self.program_state != ProgramState::Playing {
            return Err(Refused::NotNow);
        }
        self.program_state = ProgramState::Paused;
        Ok(())
    }

    /// The program ran `powerdown()` (or `power off` was accepted): POWER_OFF, the
    /// program stopped, whoever has control.
    pub fn powerdown(&mut self, now: Duration) {
        self.handle_timeout(now);
        if !matches!(self.pending, Some(Pending::SafetyRestarted { .. })) {
            self.pending = None;
            self.robot_mode = RobotMode::PowerOff;
        }
        self.program_state = ProgramState::Stopped;
        self.script = false;
    }

    /// The program itself asks for a pause (an RTDE watchdog with the action "pause"):
    /// PLAYING -> PAUSED, whoever has control.
    pub fn pause_program(&mut self, now: Duration) {
        self.handle_timeout(now);
        if self.program_state == ProgramState::Playing {
            self.program_state = ProgramState::Paused;
        }
    }

    /// `stop`: PLAYING or PAUSED -> STOPPED; a stopped program stays stopped (Ok).
    /// Refused with no program loaded.
    pub fn stop(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.handle_timeout(now);
        if self.loaded.is_none() && !self.script {
            return Err(Refused::NotNow);
        }
        self.program_state = ProgramState::Stopped;
        self.script = false;
        Ok(())
    }

    /// `set operational mode`: the dashboard controls the mode from now on.
    pub fn set_operational_mode(&mut self, mode: OperationalMode) -> Result<(), Refused> {
        self.remote()?;
        self.operational_mode = Some(mode);
        Ok(())
    }

    /// `clear operational mode`: the pendant controls it again (reported as NONE).
    pub fn clear_operational_mode(&mut self) -> Result<(), Refused> {
        self.remote()?;
        self.operational_mode = None;
        Ok(())
    }

    /// `shutdown`: the controller turns off.
    pub fn shutdown(&mut self, now: Duration) -> Result<(), Refused> {
        self.remote()?;
        self.turn_off(now);
        Ok(())
    }

    /// The controller turns off whatever the control mode, as when its power button is
    /// pressed or its process is told to end: the program stops, the arm powers off.
    pub fn turn_off(&mut self, now: Duration) {
        self.handle_timeout(now);
        self.pending = None;
        self.program_state = ProgramState::Stopped;
        self.script = false;
        self.robot_mode = RobotMode::PowerOff;
        self.shut_down = true;
    }

    /// Whether a program can start moving the arm now: the arm is RUNNING (powered,
    /// brakes released) and the safety allows motion.
    pub fn ready_for_program(&mut self, now: Duration) -> bool {
        self.handle_timeout(now);
        self.robot_mode == RobotMode::Running && self.safety.allows_motion()
    }

    /// A program sent over the primary, secondary or realtime interface starts: it
    /// replaces what ran, and the program state is PLAYING (`pause`, `play` and `stop`
    /// act on it as on a loaded one).
    pub fn script_started(&mut self) {
        self.script = true;
        self.program_state = ProgramState::Playing;
    }

    /// The running program ended (it finished, halted or failed): STOPPED.
    pub fn program_ended(&mut self) {
        self.script = false;
        self.program_state = ProgramState::Stopped;
    }

    /// Whether the current program came over the primary, secondary or realtime
    /// interface rather than from a loaded file.
    pub fn runs_script(&self) -> bool {
        self.script
    }

    /// A new id for a flight report or support file.
    pub(crate) fn next_report(&mut self) -> u32 {
        self.reports = self.reports.wrapping_add(1);
        self.reports
    }
}
