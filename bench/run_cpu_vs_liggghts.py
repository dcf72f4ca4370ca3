#!/usr/bin/env python3
"""sphdem CPU backend vs LIGGGHTS' own CPU SPH on the same 2D dam break, in one invocation.

Builds bench_dambreak if needed (CMake, CPU only), then for each size (~1e4, 1e5, 1e6 fluid
particles) runs
  * sphdem (bench/bench_dambreak.c) on 1 and on 2 OpenMP threads,
  * LIGGGHTS 3.8 (pair sph/artVisc/tensCorr + fix sph/density/continuity + fix sph/pressure +
    fix nve/sph, bench/liggghts/in.dambreak2d) on 1 MPI rank and on 2 ranks,
on identical particles (bench_dambreak --write-liggghts writes the LIGGGHTS data file), with the
same dt, the same number of warm-up steps (untimed) and timed steps. Prints a table of
fluid-particle-steps per second and the per-core ratio, and writes it to bench/RESULTS.md together
with date, commit, CPU model, machine load and the exact command. Also runs a physics cross-check
(both codes at ~1e4 to t sqrt(g/a) = 1: surge front and kinetic energy) and one 3D sphdem line.

python3 standard library only. This is a benchmark: it prints numbers and asserts nothing.

  python3 bench/run_cpu_vs_liggghts.py            # full run (< 15 min on 2 cores)
  python3 bench/run_cpu_vs_liggghts.py --quick    # smoke run, small sizes, RESULTS.md untouched
"""
import argparse
import datetime
import math
import os
import re
import resource
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TEMPLATE = os.path.join(HERE, "liggghts", "in.dambreak2d")
KEEP_MARK = "<!-- Everything below this line is kept by run_cpu_vs_liggghts.py -->"


def log(msg):
    print(msg, flush=True)


def run_timed(cmd, cwd=None, env=None):
    """Run cmd; return (stdout+stderr text, returncode, wall seconds, child CPU seconds)."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    wall = time.monotonic() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return p.stdout, p.returncode, wall, cpu


def kv(line):
    return dict(tok.split("=", 1) for tok in line.split()[1:] if "=" in tok)


def build(build_dir):
    exe = os.path.join(build_dir, "bench", "bench_dambreak")
    if not os.path.exists(os.path.join(build_dir, "CMakeCache.txt")):
        log(f"# configuring {build_dir} (CPU only)")
        subprocess.run(["cmake", "-S", ROOT, "-B", build_dir, "-DSPHDEM_CUDA=OFF", "-DSPHDEM_ENGINES=OFF",
                        "-DCMAKE_BUILD_TYPE=Release"], check=True, stdout=subprocess.DEVNULL)
    subprocess.run(["cmake", "--build", build_dir, "--target", "bench_dambreak", "-j2"], check=True,
                   stdout=subprocess.DEVNULL)
    return exe


def sphdem_run(exe, n, steps, warmup, threads, dim=2, extra=()):
    cmd = [exe, "--n", str(n), "--steps", str(steps), "--warmup", str(warmup), "--threads", str(threads),
           "--dim", str(dim), "--device", "cpu", *extra]
    load = os.getloadavg()[0]
    out, rc, wall, cpu = run_timed(cmd)
    lines = [l for l in out.splitlines() if l.startswith("BENCH")]
    if not lines:
        raise RuntimeError(f"bench_dambreak failed (rc {rc}):\n{out}")
    d = kv(lines[-1])
    d.update(load=load, proc_wall=wall, proc_cpu=cpu, cmd=" ".join(cmd), line=lines[-1])
    if d.get("status") != "ok":
        log(f"# WARNING sphdem state check: {d.get('status')}\n{out}")
    return d


def liggghts_data(exe, n, path, split):
    cmd = [exe, "--n", str(n), "--write-liggghts", path, "--liggghts-split", "1" if split else "0"]
    out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, text=True).stdout
    return kv([l for l in out.splitlines() if l.startswith("LIGGGHTS_DATA")][0])


def liggghts_run(lig, data, meta, steps, warmup, ranks, workdir, tag, dt_div=1):
    logf = os.path.join(workdir, f"log.{tag}")
    h = float(meta["h"])
    var = dict(data=data, h=meta["h"], dx=meta["dx"], c0=meta["c0"], B=meta["B"], rho0=meta["rho0"],
               gam=meta["gamma"], alpha=meta["alpha"], eta=repr(0.01 * h * h), tens=meta["tensile"],
               skin=meta["skin"], g=meta["g"], dt=repr(float(meta["dt"]) / dt_div), warmup=str(warmup), steps=str(steps),
               kernel="wendland2d", sort="1000")
    cmd = [lig, "-in", TEMPLATE, "-log", logf, "-echo", "none", "-screen", "none"]
    for k, v in var.items():
        cmd += ["-var", k, v]
    if ranks > 1:
        mpirun = shutil.which("mpirun")
        pre = [mpirun, "-np", str(ranks)]
        if os.geteuid() == 0:
            pre.insert(1, "--allow-run-as-root")
        cmd = pre + cmd
    load = os.getloadavg()[0]
    out, rc, wall, cpu = run_timed(cmd, cwd=workdir)
    text = open(logf).read() if os.path.exists(logf) else ""
    loops = re.findall(r"Loop time of ([0-9.eE+-]+) on (\d+) procs for (\d+) steps with (\d+) atoms", text)
    if rc != 0 or len(loops) < 2:
        return dict(status=f"failed (rc {rc})", error=(out + text)[-3000:], cmd=" ".join(cmd), load=load)
    loop_s, nprocs, nsteps, natoms = loops[-1]
    thermo = re.findall(r"^\s+(\d+)\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", text, re.M)
    split = {}
    last = text[text.rfind("Loop time of"):]
    for name in ("Pair", "Neigh", "Comm", "Outpt", "Other"):
        m = re.search(rf"^{name}\s+time \(%\) = \S+ \((\S+)\)", last, re.M)
        if m:
            split[name.lower()] = float(m.group(1))  # percent of the loop time
    nf = int(meta["nfluid"])
    d = dict(status="ok", wall_s=float(loop_s), ranks=int(nprocs), steps=int(nsteps), natoms=int(natoms),
             nfluid=nf, psteps_per_s=nf * int(nsteps) / float(loop_s), split=split,
             ke=float(thermo[-1][2]) if thermo else float("nan"),
             front=float(thermo[-1][3]) if thermo else float("nan"),
             load=load, proc_wall=wall, proc_cpu=cpu, cmd=" ".join(cmd))
    return d


def fmt(x, nd=3):
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x / 1e6:.{nd}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build-dir", default=os.path.join(ROOT, "build-bench"))
    ap.add_argument("--sizes", default="1e4,1e5,1e6", help="target fluid counts")
    ap.add_argument("--steps", default="300,200,20",
                    help="timed steps per size (LIGGGHTS' SPH becomes unstable after ~300-500 steps at the "
                         "sphdem dt, so the timed windows stay shorter than that)")
    ap.add_argument("--lig-dt-div", type=int, default=4,
                    help="physics check: LIGGGHTS runs at dt / this (it is unstable at the sphdem dt)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed steps before the timed ones")
    ap.add_argument("--repeat", type=int, default=2,
                    help="runs per configuration; the fastest is kept (the machine may be shared)")
    ap.add_argument("--no-mpi2", action="store_true", help="skip LIGGGHTS on 2 MPI ranks")
    ap.add_argument("--no-physics", action="store_true", help="skip the physics cross-check")
    ap.add_argument("--no-3d", action="store_true", help="skip the 3D sphdem line")
    ap.add_argument("--quick", action="store_true", help="1e4 and 1e5 only, few steps, no RESULTS.md")
    ap.add_argument("--results", default=os.path.join(HERE, "RESULTS.md"))
    ap.add_argument("--no-write", action="store_true", help="do not write RESULTS.md")
    args = ap.parse_args()
    if args.quick:
        args.sizes, args.steps, args.repeat, args.no_write = "1e4,1e5", "200,20", 1, True

    t_start = time.monotonic()
    sizes = [float(s) for s in args.sizes.split(",")]
    steps = [int(s) for s in args.steps.split(",")]
    if len(steps) != len(sizes):
        sys.exit("--steps needs one entry per size")
    exe = build(args.build_dir)
    lig = shutil.which("liggghts")
    workdir = os.path.join(args.build_dir, "liggghts_runs")
    os.makedirs(workdir, exist_ok=True)
    ncpu = os.cpu_count()
    log(f"# sphdem vs LIGGGHTS, {ncpu} CPUs, load average at start {os.getloadavg()}")

    def best(fn, key="psteps_per_s"):
        runs = [fn() for _ in range(max(1, args.repeat))]
        ok = [r for r in runs if r.get("status") == "ok"]
        if not ok:
            return runs[-1]
        b = max(ok, key=lambda r: float(r[key]))
        b["all"] = [float(r[key]) for r in ok]
        return b

    rows = []
    for n, st in zip(sizes, steps):
        row = dict(n=n, steps=st)
        for th in (1, 2):
            r = best(lambda: sphdem_run(exe, n, st, args.warmup, th))
            row[f"s{th}"] = r
            log(f"sphdem   n={r['nfluid']:>8} threads={th} steps={st}: {float(r['psteps_per_s']) / 1e6:.3f} M p-steps/s"
                f" (runs {[round(x / 1e6, 3) for x in r['all']]}, load {r['load']:.2f})")
        if lig:
            for ranks in ((1,) if args.no_mpi2 else (1, 2)):
                data = os.path.join(workdir, f"dambreak_{int(n)}_{ranks}.data")
                meta = liggghts_data(exe, n, data, split=ranks > 1)
                r = best(lambda: liggghts_run(lig, data, meta, st, args.warmup, ranks, workdir, f"{int(n)}_np{ranks}"))
                os.remove(data)
                row[f"l{ranks}"] = r
                if r["status"] == "ok":
                    log(f"LIGGGHTS n={r['nfluid']:>8} ranks={ranks}   steps={st}: {r['psteps_per_s'] / 1e6:.3f} M p-steps/s"
                        f" (runs {[round(x / 1e6, 3) for x in r['all']]}, load {r['load']:.2f}, split % {r['split']})")
                else:
                    log(f"LIGGGHTS n={n:g} ranks={ranks}: {r['status']}\n{r.get('error', '')}")
        rows.append(row)

    phys = None
    if not args.no_physics and lig:
        # both codes at ~1e4 to t sqrt(g/a) = 1 (a = 1 m): surge front and kinetic energy; LIGGGHTS
        # at dt / lig_dt_div (at the sphdem dt its SPH blows up after a few hundred steps)
        meta = liggghts_data(exe, 1e4, os.path.join(workdir, "phys.data"), split=False)
        nst = int(math.ceil(1.0 / math.sqrt(float(meta["g"])) / float(meta["dt"])))
        sp = sphdem_run(exe, 1e4, nst - args.warmup, args.warmup, 2)
        k = args.lig_dt_div
        lp = liggghts_run(lig, os.path.join(workdir, "phys.data"), meta, k * nst - args.warmup, args.warmup, 1,
                          workdir, "phys", dt_div=k)
        phys = dict(steps=nst, t=nst * float(meta["dt"]), s=sp, l=lp, k=k)
        log(f"physics check, {nst} steps sphdem, {k * nst} steps LIGGGHTS (dt/{k}) "
            f"(t sqrt(g/a) = {nst * float(meta['dt']) * math.sqrt(float(meta['g'])):.3f}):"
            f" front/a sphdem {float(sp['front']):.3f} LIGGGHTS {lp.get('front', float('nan')):.3f};"
            f" KE sphdem {float(sp['ke']):.4g} J/m LIGGGHTS {lp.get('ke', float('nan')):.4g} J/m")

    d3 = None
    if not args.no_3d:
        d3 = [sphdem_run(exe, 1e5 if not args.quick else 2e4, 20, 3, th, dim=3) for th in (1, 2)]
        for r in d3:
            log(f"sphdem 3D n={r['nfluid']} nwall={r['nwall']} threads={r['threads']}: "
                f"{float(r['psteps_per_s']) / 1e6:.3f} M p-steps/s")

    # ---- table ------------------------------------------------------------------------------
    hdr = ("| N fluid | N wall | steps | sphdem 1 thr | sphdem 2 thr | LIGGGHTS 1 rank | LIGGGHTS 2 ranks "
           "| ratio 1 core | ratio 2 cores |")
    sep = "|" + "---|" * 9
    lines = [hdr, sep]
    for row in rows:
        s1, s2 = row["s1"], row["s2"]
        l1, l2 = row.get("l1"), row.get("l2")
        ps1, ps2 = float(s1["psteps_per_s"]), float(s2["psteps_per_s"])
        pl1 = l1["psteps_per_s"] if l1 and l1["status"] == "ok" else None
        pl2 = l2["psteps_per_s"] if l2 and l2["status"] == "ok" else None
        r1 = f"{ps1 / pl1:.2f}" if pl1 else "n/a"
        r2 = f"{ps2 / pl2:.2f}" if pl2 else "n/a"
        lines.append(f"| {s1['nfluid']} | {s1['nwall']} | {row['steps']} | {fmt(ps1)} | {fmt(ps2)} | {fmt(pl1)} "
                     f"| {fmt(pl2)} | {r1} | {r2} |")
    table = "\n".join(lines)
    log("\nparticle-steps/s in millions (fluid particles x timed steps / wall time of the timed loop);")
    log("ratio = sphdem / LIGGGHTS on the same number of cores (1 thread vs 1 rank, 2 threads vs 2 ranks)\n")
    log(table)
    elapsed = time.monotonic() - t_start
    log(f"\n# total {elapsed:.0f} s, load average at end {os.getloadavg()}")
    if args.no_write:
        return

    # ---- RESULTS.md -------------------------------------------------------------------------
    def sh(cmd):
        try:
            return subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
        except OSError:
            return ""
    commit = sh(["git", "rev-parse", "--short", "HEAD"]).strip()
    dirty = " (working tree has uncommitted changes)" if sh(["git", "status", "--porcelain", "--", "gpu", "bench"]).strip() else ""
    cpu = next((l.split(":", 1)[1].strip() for l in sh(["lscpu"]).splitlines() if l.startswith("Model name")), "?")
    ligver = ""
    for row in rows:
        if row.get("l1", {}).get("status") == "ok":
            t = open(os.path.join(workdir, f"log.{int(row['n'])}_np1")).readline().strip()
            ligver = t
            break
    split_lines = ["| N fluid | code | cores | timed split |", "|---|---|---|---|"]
    for row in rows:
        for th in (1, 2):
            r = row[f"s{th}"]
            ws = float(r["wall_s"])
            parts = [f"{k[2:]} {100 * float(r[k]) / ws:.0f}%" for k in
                     ("t_sort", "t_wall", "t_rates", "t_integrate", "t_transfer", "t_reduce")]
            split_lines.append(f"| {r['nfluid']} | sphdem | {th} thr | {', '.join(parts)}; "
                               f"{r['nsorts']} resorts; {r['bytes_per_particle']} B/particle |")
        for ranks in (1, 2):
            r = row.get(f"l{ranks}")
            if r and r["status"] == "ok":
                split_lines.append(f"| {r['nfluid']} | LIGGGHTS | {ranks} rank | " +
                                   ", ".join(f"{k} {v:.0f}%" for k, v in r["split"].items()) +
                                   " (Other = fixes: density continuity, pressure, integration) |")
    cross = ["| N fluid | steps | code | cores | KE at end (J/m) | front x/a at end |", "|---|---|---|---|---|---|"]
    for row in rows:
        for key, code, c in (("s1", "sphdem", "1 thr"), ("l1", "LIGGGHTS", "1 rank")):
            r = row.get(key)
            if r and r.get("status") == "ok":
                cross.append(f"| {r['nfluid']} | {row['steps'] + args.warmup} | {code} | {c} | {float(r['ke']):.4g} | "
                             f"{float(r['front']):.4f} |")
    if phys:
        cross.append(f"| {phys['s']['nfluid']} | {phys['steps']} at dt (t sqrt(g/a) = 1) | sphdem | 2 thr | "
                     f"{float(phys['s']['ke']):.4g} | {float(phys['s']['front']):.4f} |")
        if phys["l"].get("status") == "ok":
            cross.append(f"| {phys['l']['nfluid']} | {phys['k'] * phys['steps']} at dt/{phys['k']} (t sqrt(g/a) = 1) "
                         f"| LIGGGHTS | 1 rank | "
                         f"{phys['l']['ke']:.4g} | {phys['l']['front']:.4f} |")
            cross.append(f"| | | wall time of these runs: LIGGGHTS {phys['l']['wall_s']:.1f} s (1 rank), "
                         f"sphdem {float(phys['s']['wall_s']):.1f} s (2 threads) | | | |")
    loads = []
    for row in rows:
        for key in ("s1", "s2", "l1", "l2"):
            r = row.get(key)
            if r:
                loads.append(f"{r['load']:.2f}")
    out = [
        "# CPU benchmark: sphdem vs LIGGGHTS' own SPH, 2D dam break",
        "",
        f"- date: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M %Z').strip()}",
        f"- commit: {commit}{dirty}",
        f"- CPU: {cpu}, {ncpu} logical CPUs",
        f"- LIGGGHTS: {ligver or 'not run'}",
        f"- command: `python3 bench/run_cpu_vs_liggghts.py {' '.join(sys.argv[1:])}`".replace("  ", " "),
        f"- total time of the script: {elapsed:.0f} s; each number is the best of {args.repeat} run(s); "
        f"1-minute load average before each run: {', '.join(loads)}",
        "",
        "Millions of fluid-particle-steps per second (fluid particles x timed steps / wall time of the timed",
        f"loop, after {args.warmup} untimed warm-up steps; setup, file reading and the first neighbor build",
        "are excluded on both sides). Ratio = sphdem / LIGGGHTS on equal cores (1 OpenMP thread vs 1 MPI",
        "rank, 2 threads vs 2 ranks), i.e. the per-core ratio. Target: >= 5.",
        "",
        table,
        "",
        "Where the time goes (timed steps only):",
        "",
        "\n".join(split_lines),
        "",
        "Physics cross-check (same particles, dt and number of steps on both sides):",
        "",
        "\n".join(cross),
        "",
    ]
    if d3:
        out += ["3D (sphdem only, SPHERIC-like box of width a, `bench_dambreak --dim 3`):", "",
                "| N fluid | N wall | threads | steps | M p-steps/s | split | B/particle |", "|---|---|---|---|---|---|---|"]
        for r in d3:
            ws = float(r["wall_s"])
            parts = ", ".join(f"{k[2:]} {100 * float(r[k]) / ws:.0f}%" for k in
                              ("t_sort", "t_wall", "t_rates", "t_integrate", "t_reduce"))
            out.append(f"| {r['nfluid']} | {r['nwall']} | {r['threads']} | {r['steps']} | "
                       f"{float(r['psteps_per_s']) / 1e6:.3f} | {parts} | {r['bytes_per_particle']} |")
        out.append("")
    out += ["Raw lines:", "", "```"]
    for row in rows:
        out.append(row["s1"]["line"])
        out.append(row["s2"]["line"])
    for r in (d3 or []):
        out.append(r["line"])
    out.append("```")
    out.append("")
    keep = ""
    if os.path.exists(args.results):
        old = open(args.results).read()
        if KEEP_MARK in old:
            keep = old[old.index(KEEP_MARK) + len(KEEP_MARK):]
    with open(args.results, "w") as f:
        f.write("\n".join(out) + "\n" + KEEP_MARK + (keep if keep else "\n"))
    log(f"# wrote {args.results}")


if __name__ == "__main__":
    main()
