"""Route mode past one machine: peak memory and wall time of a long synthetic route on one machine
and on local Dask workers (docs/route_mode.md, "Routes past one machine").

    python tools/route_scaling.py [--frames 20000] [--workers 2] [--shift-window 0,0]
        [--methods filter,seqslam] [--runs single,processes,threads] [--json results.jsonl]

The route: ``--frames`` reference frames of a smoothly changing random world (48 x 24 prepared
images, each place a blend of three random textures) and a query traverse of the same length
driving it at 0.9-1.1 reference frames per frame, darker and noisier (a stand-in for a night:
what is measured is memory and time, not accuracy). Each run is a fresh Python process, so its
peak resident memory (``ru_maxrss``) is its own:

* ``single``: :func:`nightloc.route.match_prepared` with ``keep_difference=False`` (what
  ``nightloc route`` holds: one float32 matrix of ``frames**2`` cells);
* ``processes``: :func:`nightloc.route.dask_backend.dask_stream_match` on a LocalCluster of
  ``--workers`` worker processes (one thread each) on loopback, as ``nightloc route --dask local
  --threads N`` runs; peak memory is the client's plus every worker's (their peaks, summed: an
  upper bound of the simultaneous total), and each process's growth over its idle size after
  start-up is reported beside it;
* ``threads``: the same with the workers as threads of the client's process (one process).

Each run prints and appends one JSON line: wall time of the matching (the cluster's start-up
excluded, reported apart), peak memory, the full matrix's size, and whether the matches equal the
single machine's (checked against a hash of the single run's matches and scores).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

MB = 1 << 20


def make_route(frames: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Prepared ``(frames, 24, 48)`` uint8 references and queries of a synthetic route."""
    rng = np.random.default_rng(seed)
    refs = np.empty((frames, 24, 48), np.uint8)
    queries = np.empty_like(refs)
    previous = rng.uniform(0, 255, (24, 48))
    current = rng.uniform(0, 255, (24, 48))
    places = []
    for index in range(frames):
        following = rng.uniform(0, 255, (24, 48))
        place = 0.25 * previous + 0.5 * current + 0.25 * following
        refs[index] = np.clip(place, 0, 255).astype(np.uint8)
        places.append(index)
        previous, current = current, following
    position = 0.0
    for index in range(frames):
        source = refs[min(frames - 1, round(position))].astype(np.float64)
        queries[index] = np.clip(0.6 * source + 20 + rng.normal(0, 12, source.shape), 0, 255).astype(np.uint8)
        position += 1.0 + 0.1 * np.sin(index / 40.0)
        position = min(position, frames - 1.0)
    return refs, queries


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kilobytes


def _current_mb() -> float:
    with open("/proc/self/statm") as stream:
        return int(stream.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / MB


def _warmed_mb() -> float:
    """A worker's resident size once the modules its tasks import are loaded (its idle size)."""
    import nightloc.route.dask_backend  # noqa: F401  (nightloc, its core, OpenCV, SciPy)

    return _current_mb()


def _digest(result) -> str:
    digest = hashlib.sha256()
    digest.update(np.ascontiguousarray(result.refs).tobytes())
    digest.update(np.ascontiguousarray(result.scores).tobytes())
    return digest.hexdigest()[:16]


def run_one(args: argparse.Namespace) -> dict:
    """One configuration in this process (``run`` subcommand)."""
    from nightloc import route

    refs = np.load(Path(args.data) / "refs.npy")
    queries = np.load(Path(args.data) / "queries.npy")
    window = tuple(int(v) for v in args.shift_window.split(",")) if args.shift_window != "default" else None
    changes = {"method": args.method, "shift_window": window}
    if args.method == "seqslam":
        changes["mode"] = "causal"
    params = route.resolve_params(None, **changes)
    idle = _current_mb()
    record: dict = {
        "run": args.run,
        "method": args.method,
        "frames": len(refs),
        "shift_window": args.shift_window,
        "matrix_mb": round(len(queries) * len(refs) * 4 / MB, 1),
        "client_idle_mb": round(idle, 1),
    }
    if args.run == "single":
        start = time.perf_counter()
        result = route.match_prepared(refs, queries, params, threads=args.workers, keep_difference=False)
        record["wall_s"] = round(time.perf_counter() - start, 2)
        record["stages_s"] = {stage: round(seconds, 2) for stage, seconds in result.timings.items()}
        del result.enhanced
        record["peak_mb"] = round(_peak_mb(), 1)
        record["client_peak_mb"] = record["peak_mb"]
    else:
        from nightloc.route.dask_backend import dask_stream_match, local_client

        start = time.perf_counter()
        with local_client(args.workers, 1, processes=args.run == "processes") as client:
            record["cluster_start_s"] = round(time.perf_counter() - start, 2)
            idle = _current_mb()  # with dask imported and the cluster started
            record["client_idle_mb"] = round(idle, 1)
            workers_idle = client.run(_warmed_mb) if args.run == "processes" else {}
            start = time.perf_counter()
            result = dask_stream_match(client, refs, queries, params)
            record["wall_s"] = round(time.perf_counter() - start, 2)
            workers_peak = client.run(_peak_mb) if args.run == "processes" else {}
        record["client_peak_mb"] = round(_peak_mb(), 1)
        record["workers_idle_mb"] = [round(v, 1) for v in workers_idle.values()]
        record["workers_peak_mb"] = [round(v, 1) for v in workers_peak.values()]
        record["peak_mb"] = round(record["client_peak_mb"] + sum(workers_peak.values()), 1)
        record["growth_mb"] = round(
            record["client_peak_mb"] - idle + sum(workers_peak[k] - workers_idle[k] for k in workers_peak), 1
        )
    record.setdefault("growth_mb", round(record["peak_mb"] - idle, 1))
    record["peak_share_of_matrix"] = round(record["peak_mb"] / record["matrix_mb"], 3)
    record["growth_share_of_matrix"] = round(record["growth_mb"] / record["matrix_mb"], 3)
    record["matches"] = _digest(result)
    return record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command")
    parser.add_argument("--frames", type=int, default=20000, help="frames of each traverse (default 20000)")
    parser.add_argument("--workers", type=int, default=2, help="Dask workers, threads of the single run (default 2)")
    parser.add_argument("--shift-window", default="0,0", help="COLUMNS,ROWS or default (default 0,0)")
    parser.add_argument("--methods", default="filter,seqslam", help="filter and/or seqslam (causal)")
    parser.add_argument("--runs", default="single,processes,threads", help="which runs (default all three)")
    parser.add_argument("--json", help="append each run's JSON line to this file")
    parser.add_argument("--data", help="folder for the route (default: a temporary one)")
    one = sub.add_parser("run", help="one configuration in this process (used by the tool itself)")
    one.add_argument("--run", required=True)
    one.add_argument("--method", required=True)
    args = parser.parse_args()
    if args.command == "run":
        sys.stdout.write(json.dumps(run_one(args)) + "\n")
        return
    with tempfile.TemporaryDirectory(prefix="route-scaling-") as scratch:
        data = Path(args.data or scratch)
        data.mkdir(parents=True, exist_ok=True)
        if not (data / "refs.npy").exists():
            refs, queries = make_route(args.frames)
            np.save(data / "refs.npy", refs)
            np.save(data / "queries.npy", queries)
        digests: dict[str, str] = {}
        for method in args.methods.split(","):
            for run in args.runs.split(","):
                command = [sys.executable, __file__, "--data", str(data), "--workers", str(args.workers)]
                command += ["--shift-window", args.shift_window, "run", "--run", run, "--method", method]
                output = subprocess.run(command, check=True, capture_output=True, text=True).stdout
                record = json.loads(output.strip().splitlines()[-1])
                digests.setdefault(method, record["matches"])
                record["equal_to_first_run"] = record["matches"] == digests[method]
                line = json.dumps(record)
                sys.stdout.write(line + "\n")
                sys.stdout.flush()
                if args.json:
                    with open(args.json, "a") as stream:
                        stream.write(line + "\n")


if __name__ == "__main__":
    main()
