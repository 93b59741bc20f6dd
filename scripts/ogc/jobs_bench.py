"""Jobs through spherefit's OGC API - Processes, timed (scripts/ogc/replicas_bench.sh runs it).

    python3 jobs_bench.py throughput URL REQUEST.json N [TOKEN]
        posts N asynchronous jobs of REQUEST.json at once (a 429 is retried after its
        Retry-After), then polls them all until each is finished; prints the wall time from the
        first POST to the last job finished and jobs per second.
    python3 jobs_bench.py latency URL REQUEST.json N [TOKEN]
        posts N jobs one after another, each polled every 5 ms until finished; prints the
        median and the spread of POST-to-successful times.

Every job must end `successful` (else exit 1). Only the standard library.
"""
import json
import statistics
import sys
import time
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor


def request(method, url, token, body=None, headers=None):
    h = dict(headers or {})
    if token:
        h["Authorization"] = f"Bearer {token}"
    req = urllib.request.Request(url, data=body, method=method, headers=h)
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def post(url, body, token):
    while True:
        status, headers, out = request(
            "POST", f"{url}processes/fit/execution", token, body,
            {"Content-Type": "application/json", "Prefer": "respond-async"})
        if status == 201:
            return json.loads(out)["jobID"]
        if status in (429, 503) and "Retry-After" in headers:
            time.sleep(min(float(headers["Retry-After"]), 2.0))
            continue
        sys.exit(f"POST: {status} {out[:300]!r}")


def wait(url, job, token, every_s):
    while True:
        status, _, out = request("GET", f"{url}jobs/{job}", token)
        if status != 200:
            sys.exit(f"GET /jobs/{job}: {status} {out[:300]!r}")
        s = json.loads(out)
        if s["status"] not in ("accepted", "running"):
            if s["status"] != "successful":
                sys.exit(f"job {job}: {s}")
            return
        time.sleep(every_s)


def main():
    mode, url, path, n = sys.argv[1:5]
    token = sys.argv[5] if len(sys.argv) > 5 else None
    url = url if url.endswith("/") else url + "/"
    body = open(path, "rb").read()
    n = int(n)
    if mode == "throughput":
        t0 = time.time()
        with ThreadPoolExecutor(16) as pool:
            jobs = list(pool.map(lambda _: post(url, body, token), range(n)))
            t_posted = time.time() - t0
            list(pool.map(lambda j: wait(url, j, token, 0.05), jobs))
        dt = time.time() - t0
        print(f"{n} jobs: posted in {t_posted:.1f} s, all successful after {dt:.1f} s: "
              f"{n / dt:.2f} jobs/s")
    elif mode == "latency":
        times = []
        for _ in range(n):
            t0 = time.time()
            job = post(url, body, token)
            wait(url, job, token, 0.005)
            times.append(time.time() - t0)
        q = statistics.quantiles(times, n=10)
        print(f"{n} jobs one at a time, POST to successful: median {1000 * statistics.median(times):.0f} ms "
              f"(10th percentile {1000 * q[0]:.0f} ms, 90th {1000 * q[-1]:.0f} ms)")
    else:
        sys.exit(f"unknown mode {mode}")


if __name__ == "__main__":
    main()
