"""Real OGC API clients against a running spherefit (.ci/ogc.sh): OWSLib lists the processes,
runs `fit` synchronously and as an asynchronous job (polls it, reads the result), and reads the
job's result collection through OGC API - Features. Prints the finished job's id on the last
line (for ogrinfo). Exits non-zero on the first thing that is not as the standard says."""
import json
import sys
import time

from owslib.ogcapi.features import Features
from owslib.ogcapi.processes import Processes

url = sys.argv[1]
data = json.load(open(sys.argv[2]))
tolerance_m = 1000

p = Processes(url)
ids = [x["id"] for x in p.processes()]
assert ids == ["fit", "interpolate", "evaluate"], ids
desc = p.process("fit")
assert desc["inputs"]["tolerance_m"]["schema"]["type"] == "number", desc["inputs"]["tolerance_m"]
print("OWSLib: processes", ids)

# Synchronous; OWSLib asks for response=document.
sync = p.execute("fit", {"data": data, "tolerance_m": tolerance_m})
features = sync["result"]["features"]
assert len(features) == len(data["features"]), (len(features), len(data["features"]))
assert all("fit" in f["properties"] for f in features)
print(f"OWSLib: fit sync, {len(features)} features")

# Asynchronous: 201, Location, poll, result.
status = p.execute("fit", {"data": data, "tolerance_m": tolerance_m}, async_=True)
job = status["jobID"]
location = p.response_headers["Location"]
assert location.endswith(f"/jobs/{job}"), location
assert status["status"] in ("accepted", "running"), status
deadline = time.time() + 120
seen = set()
while True:
    s = p._request(path=f"jobs/{job}")
    seen.add(s["status"])
    if s["status"] not in ("accepted", "running"):
        break
    assert time.time() < deadline, s
    time.sleep(0.1)
assert s["status"] == "successful", s
assert s["progress"] == 100, s
result = p._request(path=f"jobs/{job}/results")
assert result == sync["result"], "the job's result differs from the synchronous one"
print(f"OWSLib: fit async, job {job} went through {sorted(seen)}, result equals the sync one")

# The result as OGC API - Features.
f = Features(url)
assert any(c["id"] == job for c in f.collections()["collections"])
items = f.collection_items(job, limit=2)
assert items["numberMatched"] == len(features), items["numberMatched"]
assert items["numberReturned"] == min(2, len(features))
print(f"OWSLib: collection {job} has {items['numberMatched']} features")
print(job)
