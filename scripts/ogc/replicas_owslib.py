"""OWSLib through the round-robin proxy of deploy/local/replicas.sh (.ci/replicas.sh): runs `fit`
as an asynchronous job with a bearer token (OWSLib's `headers`), takes the replica that answered
the POST out of the proxy's rotation (haproxy's runtime API: `drain`), then polls the job until
it is finished: every poll is answered by the other replica, which never saw the POST (each
answer's `X-Spherefit-Replica` header says which). The result must equal a synchronous fit's.
Puts the replica back in rotation and prints the job id on the last line. The fit is the
default one (no tolerance), slow enough on the 110m world (about 1 s) to be polled several times.

    python replicas_owslib.py PROXY_URL INPUT.geojson TOKEN REPLICAS_SH DIR
"""
import json
import subprocess
import sys
import time

from owslib.ogcapi.processes import Processes

url, path, token, replicas_sh, run_dir = sys.argv[1:6]
data = json.load(open(path))
auth = {"Authorization": f"Bearer {token}"}

p = Processes(url, headers=auth)
sync = p.execute("fit", {"data": data})["result"]
status = p.execute("fit", {"data": data}, async_=True)
job = status["jobID"]
posted_on = p.response_headers.get("X-Spherefit-Replica")
assert posted_on in ("a", "b"), p.response_headers
other = "b" if posted_on == "a" else "a"
print(f"OWSLib: POST /processes/fit/execution (async) answered by replica {posted_on}: job {job}")

subprocess.run([replicas_sh, "proxy", run_dir, "drain", posted_on], check=True)
try:
    answered = []
    seen = []
    deadline = time.time() + 120
    while True:
        s = p._request(path=f"jobs/{job}")
        answered.append(p.response_headers.get("X-Spherefit-Replica"))
        seen.append(s["status"])
        if s["status"] not in ("accepted", "running"):
            break
        assert time.time() < deadline, s
        time.sleep(0.05)
    assert s["status"] == "successful", s
    result = p._request(path=f"jobs/{job}/results")
    answered.append(p.response_headers.get("X-Spherefit-Replica"))
finally:
    subprocess.run([replicas_sh, "proxy", run_dir, "ready", posted_on], check=True)
assert set(answered) == {other}, f"polls answered by {answered}, the POST by {posted_on}"
assert "running" in seen or "accepted" in seen, f"the job was finished at the first poll: {seen}"
assert result == sync, "the job's result differs from the synchronous fit's"
print(f"OWSLib: {len(answered) - 1} polls ({' -> '.join(dict.fromkeys(seen))}) and the result, "
      f"every one answered by replica {other}; the result equals the synchronous fit's")
print(job)
