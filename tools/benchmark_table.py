#!/usr/bin/python3
"""The README's table of current figures, generated from docs/benchmarks/*.json.

Usage:
  tools/benchmark_table.py                 print the table (Markdown)
  tools/benchmark_table.py --check FILE    exit 1, printing a diff, when the block between
                                           <!-- figures:begin --> and <!-- figures:end -->
                                           in FILE differs from the generated one
  tools/benchmark_table.py --write FILE    rewrite that block in FILE
  tools/benchmark_table.py --add-to-series RECORD.json SERIES.json
                                           append the float forward entries of one
                                           `dynaguide bench sim --json` record to a series
                                           as its next run, keeping its latest SERIES_RUNS
                                           runs and only the fields the table reads

Every value comes from a record that `dynaguide bench ...` or `dynaguide eval runtime`
wrote; a figure whose record is missing is left out of the table. The targets are the
ones docs/benchmarks.md states. What each record's fields mean: docs/benchmarks.md.
"""

import difflib
import json
import os
import statistics
import sys

BEGIN = "<!-- figures:begin -->"
END = "<!-- figures:end -->"
NONE = "not recorded"
PROVENANCE = ("commit", "date", "load_average_before", "load_average_after")

HERE = os.path.dirname(os.path.abspath(__file__))
BENCHMARKS = os.path.normpath(os.path.join(HERE, "..", "docs", "benchmarks"))


def load(name):
    """The records of docs/benchmarks/NAME (a list), or None when the file is missing."""
    path = os.path.join(BENCHMARKS, name)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        data = json.load(f)
    return data


def records(name):
    data = load(name)
    if data is None:
        return []
    if isinstance(data, dict):
        # runtime.json: the provenance once, beside the points
        shared = {k: data[k] for k in PROVENANCE if k in data}
        return [{**shared, **p} for p in data.get("points", [])]
    return data


def pick(name, **match):
    """The newest record of NAME whose fields equal MATCH, or None."""
    found = [r for r in records(name) if all(r.get(k) == v for k, v in match.items())]
    if not found:
        return None
    return max(found, key=lambda r: r.get("date", ""))


def pick_all(name, **match):
    """Every record of NAME matching MATCH from the newest measurement (its date)."""
    found = [r for r in records(name) if all(r.get(k) == v for k, v in match.items())]
    if not found:
        return []
    newest = max(r.get("date", "") for r in found)
    return [r for r in found if r.get("date", "") == newest]


def num(x, digits=3):
    """X to DIGITS significant digits, without an exponent for the sizes used here."""
    if x is None:
        return "?"
    if x == 0:
        return "0"
    mag = abs(x)
    decimals = digits - 1
    while mag >= 10 and decimals > 0:
        mag /= 10
        decimals -= 1
    while mag < 1 and decimals < 6:
        mag *= 10
        decimals += 1
    return f"{x:.{decimals}f}"


def mega(x):
    return f"{x / 1e6:.1f}"


def load_text(r):
    before = r.get("load_average_before")
    after = r.get("load_average_after")
    if not before or not after:
        return NONE
    return f"{before[0]:.2f} / {after[0]:.2f}"


def provenance(rs):
    """Commit, date and 1-minute load of the records RS (joined when they differ)."""
    def join(values):
        seen = []
        for v in values:
            if v not in seen:
                seen.append(v)
        return ", ".join(seen)
    commit = join(r.get("commit", NONE) for r in rs)
    date = join(r["date"][:10] if r.get("date") else NONE for r in rs)
    load_avg = join(load_text(r) for r in rs)
    return commit, date, load_avg


class Table:
    def __init__(self, base):
        self.base = base  # the folder the links are relative to
        self.rows = []

    def add(self, figure, value, target, record, rs):
        rs = [r for r in rs if r is not None]
        if not rs:
            return
        link = os.path.relpath(os.path.join(BENCHMARKS, record), self.base).replace(os.sep, "/")
        commit, date, load_avg = provenance(rs)
        self.rows.append((figure, value, target, f"[{record}]({link})", commit, date, load_avg))

    def markdown(self):
        head = ("figure", "value", "target", "record", "commit", "date", "load before / after")
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for row in self.rows:
            lines.append("| " + " | ".join(row) + " |")
        return "\n".join(lines)


def spread(r):
    """ 'min-max, N repeats' of a solver record's tet-steps/s, when recorded."""
    lo, hi, n = r.get("tet_steps_per_s_min"), r.get("tet_steps_per_s_max"), r.get("repeats")
    if lo is None or hi is None:
        return ""
    text = f" ({mega(lo)}-{mega(hi)}"
    return text + (f", median of {n})" if n else ")")


def nothing_shared(r):
    """ '; nothing shared: N M (each core alone: A / B M)', the machine's rate for
    two independent one-thread solvers stepped at once in the same run, and each
    one's rate to its own end, when recorded."""
    rate = r.get("nothing_shared_tet_steps_per_s")
    if not rate:
        return ""
    each = r.get("each_core_alone_tet_steps_per_s")
    alone = f" (each core alone: {' / '.join(mega(x) for x in each)} M)" if each else ""
    return f"; nothing shared: {mega(rate)} M{alone}"


def core_speeds(r):
    """ '; each core alone at L1 loads and stores: A / B GB/s', sampled between the
    same rounds, when recorded: a slower core slows its worker and the ratio."""
    speeds = r.get("core_load_store_gb_s")
    if not speeds:
        return ""
    return f"; each core alone at L1 loads and stores: {' / '.join(num(gb_s) for gb_s in speeds)} GB/s"


def step_split(r):
    """ '; a step: work A / B us, at the barrier C us (D in waits of 10 us or more);
    the host took E% of each core', where the two-thread record holds them."""
    working = r.get("working_us_per_step")
    if not working:
        return ""
    text = (f"; a step: work {' / '.join(num(us) for us in working)} us, at the barrier "
            f"{num(r['barrier_us_per_step'])} us ({num(r['long_waits_us_per_step'])} in waits of 10 us or more)")
    if r.get("host_took_percent"):
        text += f"; the host took {num(r['host_took_percent'])}% of each core"
    return text


def solver_rows(t):
    for threads in (1, 2):
        r = pick("sim_forward.json", mesh_tets=19551, precision="float", mode="forward",
                 threads=threads)
        if r:
            t.add(f"TLED forward, 20k-tet box, float, {threads} thread{'s' * (threads > 1)}",
                  f"{mega(r['tet_steps_per_s'])} M tet-steps/s{spread(r)}", "",
                  "sim_forward.json", [r])
    r = pick("sim_forward.json", mesh_tets=19551, precision="float", mode="forward", threads=2)
    if r and "speedup_over_1_thread" in r:
        t.add("TLED forward, 20k-tet box, float, 2 threads / 1",
              f"{num(r['speedup_over_1_thread'])}x (barrier {num(r['barrier_ns'])} ns"
              f"{nothing_shared(r)}{core_speeds(r)})", "", "sim_forward.json", [r])

    for label, source in (("20k-tet mesh file, file order", "file"),
                          ("20k-tet mesh file, nodes shuffled", "shuffled"),
                          ("the same box generated in memory, in the file's rounds", "box")):
        rs = [pick_mesh_file(threads, source) for threads in (1, 2)]
        if all(rs):
            t.add(f"TLED forward, {label}, 1 / 2 threads",
                  f"{mega(rs[0]['tet_steps_per_s'])} / {mega(rs[1]['tet_steps_per_s'])} "
                  f"M tet-steps/s (2 / 1: {num(rs[1]['speedup_over_1_thread'])}x, "
                  f"barrier {num(rs[1]['barrier_ns'])} ns{nothing_shared(rs[1])}{step_split(rs[1])}"
                  f"{core_speeds(rs[1])})", "",
                  "sim_mesh_file.json", rs)
    pairs = series_pairs("sim_mesh_file_series.json")
    if pairs:
        ratios = [two["speedup_over_1_thread"] for _, two in pairs]
        team = [two["tet_steps_per_s"] / two["nothing_shared_tet_steps_per_s"] for _, two in pairs]
        shared = [two["nothing_shared_tet_steps_per_s"] / one["tet_steps_per_s"] for one, two in pairs]
        t.add("TLED forward, 20k-tet mesh file, float, 2 / 1 threads, each run's own, over a series",
              f"median {num(statistics.median(ratios), 4)}x ({num(min(ratios))}-{num(max(ratios))}) over "
              f"{len(pairs)} runs, {sum(x >= 1.8 for x in ratios)} at 1.8x or more; two solvers sharing "
              f"nothing {num(statistics.median(shared))}x, the team at {num(statistics.median(team))} of them "
              f"(medians)", "1.8x", "sim_mesh_file_series.json", [pairs[0][1], pairs[-1][1]])
    r = pick("sim_memory.json", threads=2, mode="forward", precision="float")
    if r and r.get("resident_mb"):
        t.add("TLED forward, 20k-tet mesh file, float, 2 threads: resident memory while stepping",
              f"{num(r['resident_mb'])} MB", "", "sim_memory.json", [r])

    for mode, interval in (("combined", 8), ("volume", 8)):
        rs = [pick("sim_combined.json", mode=mode, inverse_interval_steps=interval,
                   threads=threads) for threads in (1, 2)]
        if all(rs):
            t.add(f"{mode.capitalize()} simulation (inverse beside forward), default phantom, "
                  f"forces every {interval} steps, 1 / 2 threads",
                  f"{num(rs[0]['realtime_factor'])}x / {num(rs[1]['realtime_factor'])}x real time "
                  f"(motion error {num(rs[1]['motion_error_m'] * 1e6)} um)", "",
                  "sim_combined.json", rs)


def fps_spread(r):
    """ 'N frames/s (min-max over K runs)' of a front-end record, the spread when recorded."""
    text = f"{num(r['fps'])} frames/s"
    lo, hi, n = r.get("fps_min"), r.get("fps_max"), r.get("repeats")
    if lo is None or hi is None or not n or n < 2:
        return text
    return text + f" ({num(lo)}-{num(hi)} over {n} runs)"


def series_pairs(name):
    """The (1-thread, 2-thread) float records of each run of a series, in run order."""
    runs = {}
    for r in records(name):
        if r.get("precision") == "float" and r.get("mode") == "forward" and "series_run" in r:
            runs.setdefault(r["series_run"], {})[r["threads"]] = r
    return [(run[1], run[2]) for _, run in sorted(runs.items()) if 1 in run and 2 in run]


# A series holds the spread of one figure over repeated runs; of each run it
# keeps what the table reads and the run's provenance, one entry per line.
SERIES_RUNS = 30
SERIES_FIELDS = ("mesh", "threads", "precision", "mode", "tet_steps_per_s", "speedup_over_1_thread",
                 "nothing_shared_tet_steps_per_s", "cpu", "series_run") + PROVENANCE


def add_to_series(record_path, series_path):
    with open(record_path) as f:
        record = json.load(f)
    series = []
    if os.path.exists(series_path):
        with open(series_path) as f:
            series = json.load(f)
    run = max((r["series_run"] for r in series), default=0) + 1
    series += [{**r, "series_run": run} for r in record
               if r.get("precision") == "float" and r.get("mode") == "forward"]
    kept_runs = sorted({r["series_run"] for r in series})[-SERIES_RUNS:]
    series = [{k: r[k] for k in SERIES_FIELDS if k in r} for r in series if r["series_run"] in kept_runs]
    with open(series_path, "w") as f:
        f.write("[\n" + ",\n".join("  " + json.dumps(r) for r in series) + "\n]\n")


def pick_mesh_file(threads, source):
    """The float record of the 20k file ('file'), its shuffled copy ('shuffled')
    or the generated box timed in the same rounds ('box')."""
    def source_of(mesh):
        shuffled = "shuffled" in mesh
        if mesh.startswith("Gmsh box"):
            return "box, shuffled" if shuffled else "box"
        return "shuffled" if shuffled else "file"
    found = [r for r in records("sim_mesh_file.json")
             if r.get("threads") == threads and r.get("mode") == "forward"
             and r.get("precision") == "float" and source_of(r.get("mesh", "")) == source]
    return max(found, key=lambda r: r.get("date", "")) if found else None


def run_rows(t):
    for policy in ("offline", "realtime"):
        rs = pick_all("run.json", policy=policy)
        if not rs:
            continue
        threads = rs[0].get("threads")
        n = len(rs)
        med = lambda key: statistics.median(r[key] for r in rs)
        rng = lambda key: f"{num(min(r[key] for r in rs))}-{num(max(r[key] for r in rs))}"
        latency = (f"latency {num(med('latency_ms_median'))} ms median "
                   f"({rng('latency_ms_median')}), p95 {num(med('latency_ms_p95'))} ms "
                   f"({rng('latency_ms_p95')})")
        drops = [r.get("dropped", 0) for r in rs]
        clean = sum(1 for d in drops if d == 0)
        if policy == "offline":
            t.add(f"Whole graph on the default phantom, no annotated video, offline, {threads} threads, "
                  f"{n} runs in one process", f"{num(med('realtime_factor'))}x real time median "
                  f"({rng('realtime_factor')}); {latency}", "", "run.json", rs)
        else:
            dropped = ("no drop in any run" if clean == n else
                       f"no drop in {clean} of {n} runs, at most {max(drops)} "
                       f"of {rs[0].get('frames')} frames")
            t.add(f"Whole graph on the default phantom, no annotated video, real time, {threads} threads, "
                  f"{n} runs in one process", f"{dropped}; {latency}", "no drop", "run.json", rs)
        shown = [r["overlays"] for r in rs if "overlays" in r]
        if shown:
            with_layers = sum(o["frames_with_layers"] for o in shown)
            composed = sum(o["composed_frames"] for o in shown)
            draws = ", ".join(f"{name} {num(statistics.median(o['draw_ms_median'][name] for o in shown))}"
                              for name in shown[0]["draw_ms_median"])
            t.add(f"What is shown, {policy}, {threads} threads: layers over the simulated frames, their age, "
                  f"each overlay's draw in the run",
                  f"{with_layers} of {composed} frames with every layer; age median "
                  f"{max(o['layer_age_median_frames'] for o in shown)} / max "
                  f"{max(o['layer_age_max_frames'] for o in shown)} frames; draw ms median {draws}",
                  "age 0 / max 1, layers on 98%", "run.json", rs)


def front_end_rows(t):
    for codec in ("raw", "huffyuv"):
        r = pick("vision.json", codec=codec, threads=2)
        if r:
            t.add(f"Stereo front end per frame, {codec} video, 2 threads",
                  f"{num(r['ms_median'])} ms median, {num(r['ms_p95'])} ms p95; "
                  f"{fps_spread(r)}", "10 ms median, 20 ms p95", "vision.json", [r])
    r = pick("pipeline.json", mode="graph", threads=2)
    if r:
        t.add("Front-end flow graph, offline, 2 threads",
              f"{num(r['realtime_factor'])}x real time, {fps_spread(r)}; "
              f"overhead over a plain loop {num(r['overhead_pct'])}%", "3x real time",
              "pipeline.json", [r])


def register_rows(t):
    rs = [pick("register.json", threads=threads) for threads in (1, 2)]
    if all(rs):
        t.add("Registration (5 fiducials, 3 cycles), 1 / 2 threads",
              f"{num(rs[0]['ms_median'])} / {num(rs[1]['ms_median'])} ms median", "under 2 s",
              "register.json", rs)
        r = rs[1]
        t.add("Registration against the default phantom's truth",
              f"rotation {num(r['rotation_error_deg'])} deg, translation "
              f"{num(r['translation_error_mm'])} mm, shift {num(r['phase_shift_error_ms'])} ms "
              f"from the clock offset; "
              f"residual {num(r['residual_mm_left'])} / {num(r['residual_mm_right'])} mm",
              "", "register.json", [r])


OVERLAYS = (
    ("mesh", "Embedded meshes overlay", "60 fps"),
    ("texture", "Surface texture overlay", "60 fps"),
    ("volume", "CT volume overlay", "15 fps"),
    ("composite", "Compositing + Inverse Realism", "3 ms"),
)


def overlay_rows(t):
    for name, label, target in OVERLAYS:
        rs = [pick("overlay.json", overlay=name, threads=threads) for threads in (1, 2)]
        if all(rs):
            t.add(f"{label}, 1 / 2 threads",
                  f"{num(rs[0]['ms_median'])} / {num(rs[1]['ms_median'])} ms median "
                  f"({num(rs[0]['fps'])} / {num(rs[1]['fps'])} fps)", target, "overlay.json", rs)


def preop_rows(t):
    r = pick("preop.json", bench="preop")
    if not r:
        return
    t.add(f"Preoperative model from the default phantom's 4D CT, {r['threads']} threads",
          f"{num(r['wall_s'])} s; {r['tets']} tets", "180 s", "preop.json", [r])
    t.add("Preoperative node motion error, mean / max",
          f"{num(r['node_error_mean_mm'])} / {num(r['node_error_max_mm'])} mm",
          "0.3 / 1.0 mm", "preop.json", [r])
    t.add("Preoperative fiducials: deformed / found in the CT, mean error",
          f"{num(r['fiducial_deformed_mean_mm'])} / {num(r['fiducial_found_mean_mm'])} mm",
          "0.24 mm (paper)", "preop.json", [r])


def runtime_rows(t):
    best = [p for p in records("runtime.json") if p.get("recommended")]
    if not best:
        return
    p = best[0]
    t.add(f"Recommended point of the error-against-run-time sweep ({p['tets']} tets, "
          f"dt {num(p['dt_ms'], 2)} ms, {p['target_features']} features, "
          f"{p['threads']} threads)",
          f"{num(p['simulating_realtime_factor'])}x real time while simulating; internal RMS "
          f"{num(p['internal_rms_mm'])} mm, surface RMS {num(p['surface_rms_mm'])} mm",
          "1x real time", "runtime.json", [p])


def generate(base):
    t = Table(base)
    solver_rows(t)
    run_rows(t)
    front_end_rows(t)
    register_rows(t)
    overlay_rows(t)
    preop_rows(t)
    runtime_rows(t)
    return t.markdown()


def split(text, path):
    begin, end = text.find(BEGIN), text.find(END)
    if begin < 0 or end < begin:
        sys.exit(f"benchmark_table: {path} has no {BEGIN} ... {END} block; "
                 f"add the two markers where the table goes")
    return text[:begin + len(BEGIN)], text[begin + len(BEGIN):end], text[end:]


def main(argv):
    if len(argv) == 1:
        print(generate(os.getcwd()))
        return 0
    if len(argv) == 4 and argv[1] == "--add-to-series":
        add_to_series(argv[2], argv[3])
        return 0
    if len(argv) != 3 or argv[1] not in ("--check", "--write"):
        print(__doc__, file=sys.stderr)
        return 2
    path = argv[2]
    with open(path) as f:
        text = f.read()
    head, block, tail = split(text, path)
    wanted = "\n" + generate(os.path.dirname(os.path.abspath(path))) + "\n"
    if argv[1] == "--write":
        if block != wanted:
            with open(path, "w") as f:
                f.write(head + wanted + tail)
        return 0
    if block == wanted:
        return 0
    sys.stdout.writelines(difflib.unified_diff(
        block.splitlines(keepends=True), wanted.splitlines(keepends=True),
        f"{path} (figures block)", "generated from docs/benchmarks/*.json"))
    print(f"benchmark_table: {path}'s figures table is stale; run "
          f"tools/benchmark_table.py --write {path}")
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
