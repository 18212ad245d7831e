#!/usr/bin/env python3
"""Issue 32's probes of experiment sessions, bounded, against a built binary.

Not run by `cargo test` (it takes minutes and measures times): run by hand
from the repository root, where `scenes/` is, to re-measure the figures of
the issue's closing note, before and after a change:

    python3 tests/python/experiment_probe.py target/release/lightbooth /tmp/probe-db

It starts `serve --mock --mock-speed 0` on a free loopback port with an
SQLite file in the given folder (reused if it holds a set-up experiment;
otherwise it calibrates the simulated display, measures WHITE's patch and
waits for its comparisons, minutes on a busy machine), then:

- race: 15 tries of a session's last trial posted together with four posts
  of the position after it; counts the connections closed without a
  response and the statuses;
- jobs: one `GET /api/jobs` (median of 5) with no session, then with 300
  sessions started and left (two trials each), its time and size; then 50
  clients polling it 10 times each, the median and 95th percentile;
- kill: 10 runs of the last trial posted while the daemon is killed with
  SIGKILL a few milliseconds later, then restarted: how many sessions came
  back running with all their trials (stuck), and whether the observer can
  start again.

- bugs: each of the issue's other session findings, one line each:
  whether it still reproduces (two tabs, a contradictory trial, the display
  rewritten after the end, a scene measurement verifying the display, a
  60 KB name, a 4-element drive, a seed over 2⁵³).

Each probe prints one line (bugs: one per finding); `--only race,jobs,kill,bugs`
picks some.
"""

import argparse
import json
import os
import random
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
import http.client

TOKEN = "probe-token-0123456789abcdef0123"
FRAME_MS = 16.7


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Daemon:
    def __init__(self, binary, folder):
        self.binary, self.folder = binary, folder
        self.port = free_port()
        self.proc = None

    def start(self):
        token = os.path.join(self.folder, "token")
        with open(token, "w") as f:
            f.write(TOKEN + "\n")
        os.chmod(token, 0o600)
        log = open(os.path.join(self.folder, "daemon.log"), "a")
        self.proc = subprocess.Popen(
            [self.binary, "serve", "--mock", "--mock-speed", "0", "--config", "/dev/null",
             "--db", "sqlite://" + os.path.join(self.folder, "lab.sqlite"),
             "--bind", f"127.0.0.1:{self.port}", "--token-file", token],
            stdout=log, stderr=log)
        for _ in range(600):
            try:
                if self.call("GET", "/api/health")[0] == 200:
                    return
            except OSError:
                pass
            time.sleep(0.1)
        raise SystemExit("the daemon did not answer; see " + os.path.join(self.folder, "daemon.log"))

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait()

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.kill()

    def call(self, method, path, body=None, timeout=120):
        """(status, parsed body, bytes); raises on a connection closed without a response."""
        c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout)
        headers = {"Authorization": "Bearer " + TOKEN}
        data = None
        if body is not None:
            data = json.dumps(body)
            headers["Content-Type"] = "application/json"
        c.request(method, path, body=data, headers=headers)
        r = c.getresponse()
        raw = r.read()
        c.close()
        try:
            parsed = json.loads(raw) if raw else None
        except ValueError:
            parsed = None
        return r.status, parsed, raw


def measure(d, body):
    s, m, _ = d.call("POST", "/api/measurements", body)
    assert s == 202, m
    while True:
        _, m, _ = d.call("GET", f"/api/measurements/{m['id']}")
        if m["state"] not in ("queued", "running"):
            assert m["state"] == "complete", m
            return m["id"]
        time.sleep(0.05)


def set_up(d):
    """An experiment of 6 trials (nstep3, one repeat): its id."""
    _, experiments, _ = d.call("GET", "/api/experiments")
    if experiments:
        return experiments[-1]["id"]
    _, plan, _ = d.call("GET", "/api/display-profiles/plan?steps=4")
    patches = []
    for p in plan["patches"]:
        assert d.call("POST", "/api/mock/display", {"drive": p["drive"]})[0] == 204
        patches.append({"drive": p["drive"], "measurement_id": measure(d, {"samples": 2})})
    s, profile, _ = d.call("POST", "/api/display-profiles", {"name": "simulated CRT", "patches": patches})
    assert s == 201, profile
    m = measure(d, {"scene": "white", "target": "patch", "samples": 3})
    print("waiting for the comparisons of WHITE's patch (renders)…", file=sys.stderr)
    while len(d.call("GET", f"/api/measurements/{m}/comparisons")[1] or []) < 7:
        time.sleep(1)
    s, e, _ = d.call("POST", "/api/experiments", {
        "measurement_id": m, "display_profile_id": profile["id"], "approximations": ["nstep3"],
        "presentation": {"repeats": 1}, "seed": 3})
    assert s == 201, e
    return e["id"]


def trial(position):
    return {"position": position, "response": 0, "reaction_ms": 600.0, "stimulus_frames": 18,
            "dropped_frames": 0, "dropped_in_stimulus": False, "frame_intervals_ms": [FRAME_MS] * 100}


def session(d, experiment, observer, trials):
    s, v, _ = d.call("POST", f"/api/experiments/{experiment}/sessions", {"observer": observer})
    assert s == 200, v
    sid = v["session"]["id"]
    d.call("POST", f"/api/experiment-sessions/{sid}/display", {"frame_ms": FRAME_MS, "client": "probe"})
    for p in range(trials):
        s, v, _ = d.call("POST", f"/api/experiment-sessions/{sid}/trials", trial(p))
        assert s == 200, v
    return sid


def race(d, experiment, tag):
    closed, statuses = 0, {}
    for attempt in range(15):
        sid = session(d, experiment, f"race{tag}{attempt}", 5)
        results = []

        def post(position):
            try:
                results.append(d.call("POST", f"/api/experiment-sessions/{sid}/trials", trial(position))[0])
            except (OSError, http.client.HTTPException):
                results.append("closed")

        threads = [threading.Thread(target=post, args=(p,)) for p in (5, 6, 6, 6, 6)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for r in results:
            statuses[r] = statuses.get(r, 0) + 1
        closed += results.count("closed")
    print(f"race: {closed} connections closed without a response in 15 tries; answers {statuses}")


def jobs(d, experiment, tag):
    def one():
        t = time.perf_counter()
        s, _, raw = d.call("GET", "/api/jobs")
        assert s == 200
        return time.perf_counter() - t, len(raw)

    before = sorted(one() for _ in range(5))[2]
    for i in range(300):
        session(d, experiment, f"left{tag}{i}", 2)
    after = sorted(one() for _ in range(5))[2]
    times = []

    def poll():
        for _ in range(10):
            times.append(one()[0])

    threads = [threading.Thread(target=poll) for _ in range(50)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    times.sort()
    print(f"jobs: one call {before[0] * 1000:.1f} ms, {before[1]} bytes before; with 300 abandoned sessions "
          f"{after[0] * 1000:.1f} ms, {after[1]} bytes; 50 pollers × 10: p50 {statistics.median(times) * 1000:.0f} ms, "
          f"p95 {times[int(0.95 * len(times))] * 1000:.0f} ms")


def kill(d, experiment, tag):
    stuck, blocked = 0, 0
    for run in range(10):
        observer = f"kill{tag}{run}"
        sid = session(d, experiment, observer, 5)
        t = threading.Thread(target=lambda: _quiet(d, sid))
        t.start()
        time.sleep(random.uniform(0.0, 0.02))
        d.kill()
        t.join()
        d.start()
        _, v, _ = d.call("GET", f"/api/experiment-sessions/{sid}")
        if v["session"]["state"] == "running" and v["next"] is None:
            stuck += 1
        s, again, _ = d.call("POST", f"/api/experiments/{experiment}/sessions", {"observer": observer})
        if s != 200 or (again["session"]["id"] == sid and again["next"] is None):
            blocked += 1
    print(f"kill: 10 runs of kill -9 during the last trial: {stuck} sessions came back running with all their "
          f"trials; {blocked} observers could not start again")


def bugs(d, experiment, tag):
    def line(name, reproduced, detail):
        print(f"bugs: {name}: {'REPRODUCED' if reproduced else 'not reproduced'} ({detail})")

    # Two tabs starting one observer at once, 10 tries.
    doubled = 0
    for i in range(10):
        ids = []
        threads = [threading.Thread(target=lambda: ids.append(d.call(
            "POST", f"/api/experiments/{experiment}/sessions", {"observer": f"tab{tag}{i}"})[1]["session"]["id"]))
            for _ in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        doubled += len(set(ids)) > 1
    line("two tabs, two running sessions", doubled > 0, f"{doubled} of 10 tries")
    # Contradictory trials.
    sid = session(d, experiment, f"contra{tag}", 0)
    stored = []
    for field, value in [("stimulus_frames", 0), ("stimulus_frames", 4000000000), ("dropped_in_stimulus", True),
                         ("reaction_ms", 0), ("reaction_ms", 3599999), ("frame_intervals_ms", [])]:
        t = trial(len(stored))
        t[field] = value
        s, v, _ = d.call("POST", f"/api/experiment-sessions/{sid}/trials", t)
        if s == 200:
            stored.append(f"{field}={value}")
    line("contradictory trials stored", bool(stored), ", ".join(stored) or "every one refused")
    # The display of a completed session.
    sid = session(d, experiment, f"ended{tag}", 6)
    s, v, _ = d.call("POST", f"/api/experiment-sessions/{sid}/display", {"frame_ms": 33.3, "client": "changed after the end"})
    line("display rewritten after the end", s == 200, f"HTTP {s}")
    # The booth's scene measurement as the display's emission.
    _, e, _ = d.call("GET", f"/api/experiments/{experiment}")
    s, v, _ = d.call("POST", f"/api/experiments/{experiment}/verifications", {
        "patches": [{"colour": "original", "geometry": "full_field", "measurement_id": e["measurement_id"]}]})
    line("scene measurement verifies the display", s == 201, f"HTTP {s}" + (f", passed {v['passed']}" if s == 201 else ""))
    # A 60 KB name with NUL and ESC.
    body = {"name": "x" * 60000 + "\u0000\u001b", "measurement_id": e["measurement_id"],
            "display_profile_id": e["display_profile_id"], "approximations": ["nstep3"]}
    s, v, _ = d.call("POST", "/api/experiments", body)
    line("60 KB name with NUL and ESC stored", s == 201, f"HTTP {s}")
    # A 4-element drive.
    s, v, _ = d.call("POST", "/api/mock/display", {"drive": [0.1, 0.2, 0.3, 0.4]})
    message = (v or {}).get("error", {}).get("message", "")
    line("4-element drive not named", "drive" not in message, message)
    # A seed over 2^53.
    body = dict(body, name="seed", seed=9043539040596399293)
    s, v, _ = d.call("POST", "/api/experiments", body)
    line("seed over 2^53 stored", s == 201, f"HTTP {s}")


def _quiet(d, sid):
    try:
        d.call("POST", f"/api/experiment-sessions/{sid}/trials", trial(5), timeout=10)
    except (OSError, http.client.HTTPException):
        pass


def main():
    a = argparse.ArgumentParser()
    a.add_argument("binary")
    a.add_argument("folder")
    a.add_argument("--only", default="race,jobs,kill,bugs")
    args = a.parse_args()
    os.makedirs(args.folder, exist_ok=True)
    d = Daemon(os.path.abspath(args.binary), args.folder)
    d.start()
    try:
        experiment = set_up(d)
        tag = str(int(time.time()))
        for probe in filter(None, args.only.split(",")):
            {"race": race, "jobs": jobs, "kill": kill, "bugs": bugs}[probe](d, experiment, tag)
    finally:
        d.stop()


if __name__ == "__main__":
    main()
