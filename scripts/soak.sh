#!/usr/bin/env bash
# Soak test: mixed good, bad, heavy and slow clients against a release server on
# loopback for SOAK_S seconds (default 180). Reports requests by status, p50/p99 latency of the
# good requests, /health p99, the server's peak RSS, and whether every fitting slot was free at
# the end. Bounded: the server stops itself after SOAK_S + 60 s.
# Usage: scripts/soak.sh   (SOAK_S, SOAK_PORT (default 18250), SOAK_CLIENTS (default 8))
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/.." && pwd)"
cd "$ROOT"
SOAK_S="${SOAK_S:-180}"
PORT="${SOAK_PORT:-18250}"
CLIENTS="${SOAK_CLIENTS:-8}"
cargo build --release --quiet
"$ROOT/target/release/spherefit" serve --addr "127.0.0.1:$PORT" --exit-after-s $((SOAK_S + 60)) \
  --timeout-s 3 --body-timeout-s 2 --header-timeout-s 2 --log-format json 2>/dev/null &
PID=$!
trap 'kill "$PID" 2>/dev/null || true; wait "$PID" 2>/dev/null || true' EXIT
for _ in $(seq 50); do
  curl -fsS "http://127.0.0.1:$PORT/health" >/dev/null 2>&1 && break
  sleep 0.1
done
python3 - "$PORT" "$SOAK_S" "$CLIENTS" "$PID" <<'PY'
import json, math, random, socket, sys, threading, time
from collections import Counter
port, dur, clients, pid = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
end = time.time() + dur
lock = threading.Lock()
status = Counter()
lat = {"good": [], "health": []}
peak = [0]

def request(method, path, ctype, body, timeout=30):
    s = socket.create_connection(("127.0.0.1", port), timeout=timeout)
    try:
        head = f"{method} {path} HTTP/1.1\r\nhost: x\r\ncontent-type: {ctype}\r\ncontent-length: {len(body)}\r\nconnection: close\r\n\r\n"
        s.sendall(head.encode() + body)
        data = b""
        while True:
            c = s.recv(65536)
            if not c:
                break
            data += c
        return int(data.split(b" ", 2)[1]) if data else 0
    except OSError:
        return -1
    finally:
        s.close()

def line(n, lon0):
    return [[round(lon0 + i * 0.01, 6), round(math.sin(i * 0.1), 6)] for i in range(n)]

HEAVY = json.dumps({"type": "LineString", "coordinates": [[round(-170 + 340 * i / 200000, 6), round(30 * math.sin(i * 0.001) + (i % 7) * 0.01, 6)] for i in range(200000)]}).encode()

def record(kind, code, t0):
    with lock:
        status[(kind, code)] += 1
        if kind in lat and code == 200:
            lat[kind].append(time.time() - t0)

def good():
    while time.time() < end:
        t0 = time.time()
        body = json.dumps({"type": "LineString", "coordinates": line(random.randint(10, 2000), random.uniform(-170, 160))}).encode()
        record("good", request("POST", "/v1/fit", "application/geo+json", body), t0)

def bad():
    cases = [("/v1/fit", "application/geo+json", b"{not json"),
             ("/v1/fit", "text/plain", b"{}"),
             ("/v1/fit?samples=100000", "application/geo+json", json.dumps({"type": "MultiLineString", "coordinates": [line(2, i) for i in range(400)]}).encode()),
             ("/v1/fit", "application/geo+json", json.dumps({"type": "LineString", "coordinates": [[0, 0], [1, 95]]}).encode()),
             ("/v1/evaluate?samples=5", "application/geo+json", json.dumps({"crs": "lonlat", "degree": 1, "knots": [0, 0, 5e-324, 5e-324], "control_points": [[0, 0], [10, 0]]}).encode()),
             ("/v1/nope", "application/json", b"{}")]
    while time.time() < end:
        t0 = time.time()
        p, c, b = random.choice(cases)
        record("bad", request("POST", p, c, b), t0)

def heavy():
    while time.time() < end:
        t0 = time.time()
        record("heavy", request("POST", "/v1/fit?control_points=10000&iterations=1000", "application/geo+json", HEAVY), t0)

def slow():
    while time.time() < end:
        t0 = time.time()
        s = socket.create_connection(("127.0.0.1", port), timeout=10)
        try:
            if random.random() < 0.5:
                s.sendall(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\n")  # never finishes the header
            else:
                s.sendall(b"POST /v1/fit HTTP/1.1\r\nhost: x\r\ncontent-type: application/geo+json\r\ncontent-length: 100000\r\n\r\n{\"type\":")
            data = s.recv(4096)
            code = int(data.split(b" ", 2)[1]) if data else 0  # 0: closed by the server
        except OSError:
            code = -1
        finally:
            s.close()
        record("slow", code, t0)

def health():
    while time.time() < end:
        t0 = time.time()
        record("health", request("GET", "/health", "text/plain", b""), t0)
        time.sleep(0.2)

def rss():
    while time.time() < end + 5:
        try:
            for l in open(f"/proc/{pid}/status"):
                if l.startswith("VmHWM:"):
                    peak[0] = max(peak[0], int(l.split()[1]))
        except OSError:
            pass
        time.sleep(0.5)

kinds = [good] * max(1, clients - 4) + [bad, heavy, slow, health]
threads = [threading.Thread(target=k, daemon=True) for k in kinds] + [threading.Thread(target=rss, daemon=True)]
for t in threads:
    t.start()
for t in threads[:-1]:
    t.join()
time.sleep(2)
import urllib.request
m = urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics").read().decode()
gauge = {l.split()[0]: float(l.split()[1]) for l in m.splitlines() if l.startswith("spherefit_fits_")  and " " in l and not l.startswith("#") and "{" not in l}
def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(q * len(xs)))] * 1000 if xs else float("nan")
print(f"soak: {dur:.0f} s, {len(kinds)} client threads")
for (k, c), n in sorted(status.items()):
    print(f"  {k:7s} {c:4d}  {n}")
print(f"good 200: p50 {pct(lat['good'], .5):.1f} ms, p99 {pct(lat['good'], .99):.1f} ms; /health p99 {pct(lat['health'], .99):.1f} ms")
print(f"peak RSS {peak[0] / 1024:.0f} MiB")
free = gauge.get("spherefit_fits_in_progress", -1) == 0 and gauge.get("spherefit_fits_waiting", -1) == 0
print(f"every slot free at the end: {free} ({gauge})")
sys.exit(0 if free else 1)
PY
