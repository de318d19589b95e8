"""Hostile probe: tries every way out of the sandbox and writes what it found to /output."""

import json
import os
import socket
import time

import zenoh

from simhost import _transport

found: dict = {"env": dict(os.environ), "mounts": open("/proc/self/mounts").read(),
               "uid": os.getuid()}


def tcp(host: str, port: int) -> str:
    try:
        s = socket.create_connection((host, port), timeout=2)
        s.close()
        return "connected"
    except OSError as e:
        return f"failed: {e}"


found["tcp_outside"] = tcp("1.1.1.1", 53)
found["tcp_host_gateway"] = tcp("172.17.0.1", 22)
found["tcp_host_loopback"] = tcp("127.0.0.1", 7447)
try:
    socket.getaddrinfo("pypi.org", 443)
    found["dns"] = "resolved"
except OSError as e:
    found["dns"] = f"failed: {e}"

session = zenoh.open(_transport.agent_config(os.environ["EAGC_ENDPOINT"]))
found["zid"] = str(session.info.zid())
seen: list[str] = []
sub = session.declare_subscriber("**", lambda s: seen.append(str(s.key_expr)))
replies = []
for selector in ("**", "@/**", "eagc/**", "@/*/router/**"):
    for r in session.get(selector, timeout=2.0):
        replies.append({"selector": selector, "key": str(r.ok.key_expr) if r.ok else None,
                        "payload": r.ok.payload.to_bytes().decode("latin-1") if r.ok else
                        r.err.payload.to_bytes().decode("latin-1")})
time.sleep(1.0)
found["get_replies"] = replies
found["sub_seen"] = sorted(set(seen))
try:
    for r in session.liveliness().get("**", timeout=1.0):
        replies.append({"selector": "liveliness **", "key": str(r.ok.key_expr) if r.ok else None})
except Exception as e:  # noqa: BLE001
    found["liveliness_error"] = str(e)
found["root_writable"] = os.access("/", os.W_OK)
try:
    open("/etc/evil", "w").write("x")
    found["write_etc"] = "written"
except OSError as e:
    found["write_etc"] = f"failed: {e}"
with open("/output/probe.json", "w") as f:
    json.dump(found, f, indent=1)
session.close()
