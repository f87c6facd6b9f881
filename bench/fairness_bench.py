"""Fairness between tenants: tenant B's small ComputeSdf latency, idle and
while tenant A runs 32 concurrent passes, on one meshgauge-server.

  PYTHONPATH=build/python /usr/bin/python3 bench/fairness_bench.py [CAP]

CAP: --max_computations_per_tenant (empty or absent: the server's default).
Binaries from build/ (MESHGAUGE_BUILD overrides)."""
import hashlib
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from meshgauge_client import MeshGaugeClient
BUILD = os.environ.get("MESHGAUGE_BUILD", "build")
cap = sys.argv[1] if len(sys.argv) > 1 else ""
tok = tempfile.NamedTemporaryFile("w", delete=False)
for t in ("alice", "bob"):
    tok.write(f"{t} {hashlib.sha256((t+'-secret').encode()).hexdigest()}\n")
tok.close()
port_file = tempfile.mktemp()
args = [os.path.join(BUILD, "server", "meshgauge-server"), "--address", "127.0.0.1:0", "--port_file", port_file,
        "--metrics_address", "", "--auth_tokens_file", tok.name]
if cap: args += ["--max_computations_per_tenant", cap, "--max_concurrent_computations", "64"]
srv = subprocess.Popen(args, stderr=subprocess.DEVNULL)
while not os.path.exists(port_file) or not open(port_file).read().strip(): time.sleep(0.05)
target = "127.0.0.1:" + open(port_file).read().strip()
def sphere(n):
    # icosphere-ish via the CLI shape
    p = tempfile.mktemp(suffix=".obj")
    subprocess.run([os.path.join(BUILD, "client", "meshgauge"), "shape", "sphere", "--out", p, "--size", str(n)], check=True, stdout=subprocess.DEVNULL)
    return p
big, small = sphere(0.03), sphere(0.3)
A = MeshGaugeClient(target, token="alice-secret"); B = MeshGaugeClient(target, token="bob-secret")
sa = A.session_from_file(big); sb = B.session_from_file(small)
def bob_lat(n=20):
    out = []
    for i in range(n):
        t = time.time(); sb.sdf(rays=16 + i % 3); out.append(time.time() - t)
    return statistics.median(out), max(out)
idle = bob_lat()
stop = False
def alice(i):
    k = 0
    while not stop:
        sa.sdf(rays=20 + (i * 7 + k) % 13); k += 1
ts = [threading.Thread(target=alice, args=(i,)) for i in range(32)]
for t in ts: t.start()
time.sleep(2)
busy = bob_lat()
stop = True
for t in ts: t.join()
print(f"cap={cap or 'default'} bob idle median {idle[0]*1e3:.1f} ms max {idle[1]*1e3:.1f}; with alice's 32 passes median {busy[0]*1e3:.1f} ms max {busy[1]*1e3:.1f} ms; ratio {busy[0]/idle[0]:.1f}")
srv.terminate(); srv.wait()
