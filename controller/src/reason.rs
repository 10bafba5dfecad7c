//! Why a program paused or stopped: [`StopReason`], carried by the cell's
//! [`CellEvent::ProgramEnded`](crate::CellEvent::ProgramEnded) and by the program state
//! changes the network server reports.

use crate::SafetyStatus;

/// Why the program paused, stopped or ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum StopReason {
    /// It ran to its end.
    EndOfProgram,
    /// It ran `halt`.
    Halt,
    /// A runtime error (its message is the program event's text).
    RuntimeError,
    /// A client's new program replaced it (a controller runs one program at a time).
    Replaced,
    /// A dashboard client's `stop`.
    DashboardStop,
    /// A dashboard client's `pause`.
    DashboardPause,
    /// A dashboard client's `shutdown`.
    Shutdown,
    /// The arm was powered off (the dashboard's `power off`, a primary client's
    /// `power off`).
    PowerOff,
    /// The program ran `powerdown()`.
    Powerdown,
    /// A primary client's `stop program`.
    ClientStop,
    /// A safety stop: a protective stop (the program's `protective_stop()`, a move
    /// beyond reach, the operator's), an emergency or safeguard stop, a fault, a
    /// violation.
    Safety(SafetyStatus),
    /// An RTDE watchdog of the program with the action "pause" went off.
    RtdeWatchdog,
    /// The controller's state machine stopped it for none of the reasons above.
    Controller,
}

impl StopReason {
    /// The reason as the `reason` field of `ursock controller --json` writes it:
    /// `end_of_program`, `halt`, `runtime_error`, `replaced`, `dashboard_stop`,
    /// `dashboard_pause`, `shutdown`, `power_off`, `powerdown`, `client_stop`,
    /// `rtde_watchdog`, `controller`, or a safety status in lower case
    /// (`protective_stop`, `robot_emergency_stop`, `fault`...).
    pub fn as_str(self) -> &'static str {
        match self {
            StopReason::EndOfProgram => "end_of_program",
            StopReason::Halt => "halt",
            StopReason::RuntimeError => "runtime_error",
            StopReason::Replaced => "replaced",
            StopReason::DashboardStop => "dashboard_stop",
            StopReason::DashboardPause => "dashboard_pause",
            StopReason::Shutdown => "shutdown",
            StopReason::PowerOff => "power_off",
            StopReason::Powerdown => "powerdown",
            StopReason::ClientStop => "client_stop",
            StopReason::RtdeWatchdog => "rtde_watchdog",
            StopReason::Controller => "controller",
            StopReason::Safety(s) => match s {
                SafetyStatus::Normal => "normal",
                SafetyStatus::Reduced => "reduced",
                SafetyStatus::ProtectiveStop => "protective_stop",
                SafetyStatus::Recovery => "recovery",
                SafetyStatus::SafeguardStop => "safeguard_stop",
                SafetyStatus::SystemEmergencyStop => "system_emergency_stop",
                SafetyStatus::RobotEmergencyStop => "robot_emergency_stop",
                SafetyStatus::Violation => "violation",
                SafetyStatus::Fault => "fault",
                SafetyStatus::AutomaticModeSafeguardStop => "automatic_mode_safeguard_stop",
                SafetyStatus::SystemThreePositionEnablingStop => {
                    "system_three_position_enabling_stop"
                }
            },
        }
    }
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}
