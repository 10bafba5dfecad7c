//! Which listeners have a connection waiting, asked of the kernel in one `poll` (Linux):
//! an `accept` on an empty non-blocking listener costs the kernel a socket and a file
//! set up and torn down again, four times a step on an idle controller. Elsewhere every
//! listener is tried.

use std::net::TcpListener;

/// For each listener, whether an `accept` may find a connection (a listener absent is
/// never ready; when the kernel cannot say, every present one is).
pub(crate) fn pending<const N: usize>(listeners: [Option<&TcpListener>; N]) -> [bool; N] {
    let present = listeners.map(|l| l.is_some());
    #[cfg(target_os = "linux")]
    {
        use rustix::event::{poll, PollFd, PollFlags, Timespec};
        let Some(any) = listeners.iter().flatten().next().copied() else {
            return present;
        };
        // An absent listener's place is taken by a present one, its answer ignored.
        let mut fds = listeners.map(|l| PollFd::new(l.unwrap_or(any), PollFlags::IN));
        let zero = Timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        if poll(&mut fds, Some(&zero)).is_ok() {
            let mut ready = present;
            for (r, fd) in ready.iter_mut().zip(&fds) {
                *r = *r && !fd.revents().is_empty();
            }
            return ready;
        }
    }
    present
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_listener_is_ready_once_a_client_connects() {
        let a = TcpListener::bind("127.0.0.1:0").unwrap();
        let b = TcpListener::bind("127.0.0.1:0").unwrap();
        if cfg!(target_os = "linux") {
            assert_eq!(pending([Some(&a), None, Some(&b)]), [false, false, false]);
        }
        let _client = std::net::TcpStream::connect(b.local_addr().unwrap()).unwrap();
        let start = std::time::Instant::now();
        while pending([Some(&a), None, Some(&b)]) != [cfg!(not(target_os = "linux")), false, true] {
            assert!(start.elapsed() < std::time::Duration::from_secs(10));
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
}
