"""A stand-in for an ``ursock`` whose controller serves more than the dashboard (the
primary and RTDE servers being added), to check that ``UrController`` passes the port
options its ``--help`` lists and reads every port the ``listening`` events report.

It prints what docs/json-events.md defines: a ``listening`` event per server (``service``,
``addr``), then ``ready`` with every address. The command line is written to
``FAKE_URSOCK_ARGV``. ``FAKE_URSOCK_FLOOD=N``: after listening, N events
of kind ``rtde`` and N lines on stderr, then one event of kind ``done``.
"""

import json
import os
import socket
import sys
import time

HELP = """Usage: ursock controller [OPTIONS]

Options:
      --bind <BIND>                      Address to bind [default: 127.0.0.1]
      --dashboard-port <DASHBOARD_PORT>  The dashboard server's port (0 picks a free one)
      --primary-port <PRIMARY_PORT>      The primary interface's port (0 picks a free one)
      --rtde-port <RTDE_PORT>            The RTDE interface's port (0 picks a free one)
      --json                             One JSON event per line
"""


def main() -> None:
    args = sys.argv[1:]
    if args[:1] == ["controller"] and "--help" in args:
        print(HELP)
        return
    with open(os.environ["FAKE_URSOCK_ARGV"], "w") as f:
        json.dump(args, f)
    listeners = []
    addrs = {}
    for name in ("dashboard", "primary", "rtde"):
        flag = f"--{name}-port"
        if flag not in args or args[args.index(flag) + 1] != "0":
            sys.exit(f"fake ursock: expected {flag} 0 in {args}")
        s = socket.socket()
        s.bind(("127.0.0.1", 0))
        s.listen()
        listeners.append(s)
        addr = "127.0.0.1:%d" % s.getsockname()[1]
        addrs[name] = addr
        print(json.dumps({"event": "listening", "t": 0.0, "addr": addr, "service": name}), flush=True)
    print(json.dumps({"event": "ready", "t": 0.0, "addrs": addrs}), flush=True)
    flood = int(os.environ.get("FAKE_URSOCK_FLOOD", "0"))
    for i in range(flood):
        sys.stdout.write(json.dumps({"event": "rtde", "t": 0.0, "i": i, "pad": "x" * 200}) + "\n")
        sys.stderr.write("noise %d %s\n" % (i, "y" * 200))
    if flood:
        print(json.dumps({"event": "done", "t": 0.0}), flush=True)
    while True:
        time.sleep(1)


if __name__ == "__main__":
    main()
