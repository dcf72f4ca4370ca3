#!/usr/bin/env python3
"""sphdem CPU backend vs DualSPHysics' CPU solver on the same 2D dam break particles, in one invocation.

For each size (target fluid counts, default 1e4 and 1e5) it
  * writes the particles of bench_dambreak (`--write-liggghts`, the scene of tests/common/scene.h:
    water column a x 2a in a 5a tank, 3 layers of wall particles, dx = a/res, h = 1.3 dx,
    c0 = 10 sqrt(2 g a), artificial viscosity alpha 0.02, dt = 0.2 h / (1.2 c0));
  * turns them into a DualSPHysics case with the external case writer (--case-writer; called as
    `CASE_WRITER --data FILE --meta "LIGGGHTS_DATA ..." --dir DIR --name Case --warmup W --steps S`,
    it writes DIR/Case.xml and DIR/Case.bi4 with the same h, c0, alpha and fixed dt);
  * runs sphdem's bench_dambreak (warm-up steps untimed, then the timed steps; its BENCH line) and
    DualSPHysics (-ompthreads:T -sv:none) on 1 and 2 OpenMP threads, best of --repeat runs each.
DualSPHysics' rate comes from its own timing: the case writes PART 1 after the warm-up steps and
PART 2 after the timed steps, and the PART-2 line of its log (Time/Sec times the simulated time of
the part) is the run time of exactly the timed steps, setup and warm-up excluded. Both rates count
fluid particles only: fluid particle-steps per second.

It prints the load average, a table (N, threads, sphdem and DualSPHysics M p-steps/s, ratio) and a
least-squares fit of time per step against N (t = t0 + b N, with R^2) for each code and thread
count, and writes results.csv and results.md into --out. With --front-res R it also runs the
physics check: the surge front (max x of the fluid / a) of both codes after the same number of
steps at a/dx = R (DualSPHysics' positions from its PartCsv output).

--precision LIST (default double) runs sphdem once per entry; an entry other than "double" is passed
as `--precision P` to bench_dambreak and skipped with a note where bench_dambreak rejects it.

It builds nothing: bench_dambreak comes from --bench-exe or the first of build/, build-cpu/,
build-bench/ that has bench/bench_dambreak; DualSPHysics' binary is --dsph-bin.

  python3 bench/dsph_compare.py --dsph-bin PATH/DualSPHysics5.4CPU_linux64 \\
      --case-writer PATH/write_dsph_case.py [--sizes 1e4,1e5,1e6] [--front-res 40]

python3 standard library only. This is a benchmark: it prints numbers and asserts nothing.
"""
import argparse
import csv
import datetime
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def log(msg=""):
    print(msg, flush=True)


def kv(line):
    return dict(tok.split("=", 1) for tok in line.split()[1:] if "=" in tok)


def find_bench(exe):
    if exe:
        cands = [exe]
    else:
        cands = [os.path.join(ROOT, b, "bench", "bench_dambreak") for b in ("build", "build-cpu", "build-bench")]
    for c in cands:
        if os.path.isfile(c) and os.access(c, os.X_OK):
            return os.path.abspath(c)
    sys.exit("dsph_compare: bench_dambreak not found (tried %s); build it first "
             "(cmake --build BUILD --target bench_dambreak) or pass --bench-exe" % ", ".join(cands))


def check_peer(path, what, opt):
    if not path:
        sys.exit(f"dsph_compare: {opt} is required ({what})")
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        sys.exit(f"dsph_compare: {what} not found or not executable: {path} (pass {opt} PATH)")
    return os.path.abspath(path)


def run(cmd, cwd=None):
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    return p.stdout, p.returncode, time.monotonic() - t0


def write_case(bench, writer, n, res, warmup, steps, workdir, tag, extra=()):
    """particles of bench_dambreak at size n (or res) -> DualSPHysics case dir; returns (dir, meta)"""
    cdir = os.path.join(workdir, tag)
    os.makedirs(cdir, exist_ok=True)
    data = os.path.join(cdir, "particles.data")
    size = ["--res", str(res)] if res else ["--n", str(n)]
    out, rc, _ = run([bench, *size, *extra, "--write-liggghts", data])
    lines = [l for l in out.splitlines() if l.startswith("LIGGGHTS_DATA")]
    if rc != 0 or not lines:
        sys.exit(f"dsph_compare: bench_dambreak --write-liggghts failed (rc {rc}):\n{out}")
    meta = kv(lines[0])
    cmd = [writer, "--data", data, "--meta", lines[0], "--dir", cdir, "--name", "Case",
           "--warmup", str(warmup), "--steps", str(steps)]
    out, rc, _ = run(cmd)
    os.remove(data)
    if rc != 0 or not os.path.exists(os.path.join(cdir, "Case.bi4")):
        sys.exit(f"dsph_compare: the case writer failed (rc {rc}): {' '.join(cmd)}\n{out}")
    meta["case_cmd"] = " ".join(cmd)
    meta["case_line"] = next((l for l in out.splitlines() if l.startswith("DSPH_CASE")), "")
    return cdir, meta


def sphdem_run(bench, n, res, steps, warmup, threads, precision, extra=()):
    size = ["--res", str(res)] if res else ["--n", str(n)]
    cmd = [bench, *size, "--steps", str(steps), "--warmup", str(warmup), "--threads", str(threads), "--device", "cpu",
           *extra]
    if precision != "double":
        cmd += ["--precision", precision]
    load = os.getloadavg()[0]
    out, rc, wall = run(cmd)
    lines = [l for l in out.splitlines() if l.startswith("BENCH")]
    if not lines:
        rejected = precision != "double" and ("usage" in out or "unknown" in out.lower() or "precision" in out.lower())
        return dict(status="rejected" if rejected else f"failed (rc {rc})", error=out[-2000:], cmd=" ".join(cmd),
                    load=load)
    d = kv(lines[-1])
    d.update(load=load, proc_wall=wall, cmd=" ".join(cmd), nfluid=int(d["nfluid"]), steps=int(d["steps"]),
             wall_s=float(d["wall_s"]), psteps_per_s=float(d["psteps_per_s"]))
    d["t_step"] = d["wall_s"] / d["steps"]
    if d.get("status") != "ok":
        log(f"# WARNING sphdem state check: {d.get('status')}")
    return d


PART_RE = re.compile(r"^(\d{5})\s+([0-9.eE+-]+)\s+([\d,]+)\s+([\d,]+)\s+([\d,]+)\s+([\d,]+)\s+([0-9.eE+-]+)\s", re.M)


def num(s):
    return float(s.replace(",", ""))


def dsph_run(dsph, cdir, meta, steps, threads, outdir, svcsv=False):
    """DualSPHysics on cdir/Case; the timed steps' run time from the PART-2 line of its log"""
    if os.path.isdir(outdir):
        shutil.rmtree(outdir)
    cmd = [dsph, os.path.join(cdir, "Case"), outdir, f"-ompthreads:{threads}", "-sv:csv" if svcsv else "-sv:none",
           "-svres:0", "-svtimers:0"]
    load = os.getloadavg()[0]
    out, rc, wall = run(cmd, cwd=cdir)
    parts = PART_RE.findall(out)
    m_sim = re.search(r"Simulation Runtime\.+:\s*([0-9.eE+-]+)", out)
    m_nst = re.search(r"Steps of simulation\.+:\s*([\d,]+)", out)
    m_out = re.search(r"Excluded particles\.+:\s*([\d,]+)", out)
    m_np = re.search(r"Particles of simulation \(initial\):\s*([\d,]+)", out)
    p2 = [p for p in parts if int(p[0]) == 2]
    if rc != 0 or not p2:
        return dict(status=f"failed (rc {rc})", error=out[-3000:], cmd=" ".join(cmd), load=load)
    _, ptime, tot, nst, npsim, ncells, tseg = p2[0]
    nst = int(num(nst))
    dt = float(meta["dt"])
    timed = float(tseg) * nst * dt      # Time/Sec x simulated time of the part = run time of its steps
    nf = int(meta["nfluid"])
    d = dict(status="ok", nfluid=nf, steps=nst, wall_s=timed, t_step=timed / nst, psteps_per_s=nf * nst / timed,
             sim_runtime=float(m_sim.group(1)) if m_sim else float("nan"),
             nstep_total=int(num(m_nst.group(1))) if m_nst else -1,
             excluded=int(num(m_out.group(1))) if m_out else -1,
             np=int(num(m_np.group(1))) if m_np else -1, ncells=int(num(ncells)),
             load=load, proc_wall=wall, cmd=" ".join(cmd))
    if steps != nst:
        log(f"# WARNING DualSPHysics PART 2 holds {nst} steps, expected {steps}")
    return d


def dsph_front(outdir, nbound, a=1.0):
    """max x / a of the fluid in DualSPHysics' last PartCsv file (Idp >= nbound)"""
    files = sorted(os.path.join(d, f) for d in (outdir, os.path.join(outdir, "data")) if os.path.isdir(d)
                   for f in os.listdir(d) if re.match(r"PartCsv_\d+\.csv$", f))
    if not files:
        return float("nan"), None
    fn = max(files, key=os.path.basename)
    with open(fn) as f:
        rows = [l.rstrip("\n") for l in f if l.strip()]
    sep = ";" if rows[0].count(";") >= rows[0].count(",") else ","
    hi = next(i for i, r in enumerate(rows) if "Pos.x" in r or "Posx" in r.replace(".", ""))
    head = [h.strip() for h in rows[hi].split(sep)]
    ix = next(i for i, h in enumerate(head) if h.replace(" ", "").startswith("Pos.x"))
    iid = next(i for i, h in enumerate(head) if h.strip().startswith("Idp"))
    xmax = -1e300
    for r in rows[hi + 1:]:
        c = r.split(sep)
        try:
            if int(float(c[iid])) >= nbound:
                xmax = max(xmax, float(c[ix]))
        except (ValueError, IndexError):
            continue
    return xmax / a, fn


def linfit(ns, ts):
    """least squares t = t0 + b n; returns (t0, b, r2)"""
    k = len(ns)
    if k < 2:
        return float("nan"), float("nan"), float("nan")
    mn, mt = sum(ns) / k, sum(ts) / k
    sxx = sum((n - mn) ** 2 for n in ns)
    sxy = sum((n - mn) * (t - mt) for n, t in zip(ns, ts))
    b = sxy / sxx if sxx else float("nan")
    t0 = mt - b * mn
    sst = sum((t - mt) ** 2 for t in ts)
    sse = sum((t - t0 - b * n) ** 2 for n, t in zip(ns, ts))
    r2 = 1 - sse / sst if sst else float("nan")
    return t0, b, r2


def git_commit():
    try:
        c = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], stdout=subprocess.PIPE, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               stdout=subprocess.PIPE, text=True).stdout.strip()
        return c + ("+dirty" if dirty else "")
    except OSError:
        return "unknown"


def m(x):
    return "n/a" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x / 1e6:.3f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dsph-bin", required=True, help="DualSPHysics CPU binary (DualSPHysics5.4CPU_linux64)")
    ap.add_argument("--case-writer", required=True, help="external tool writing Case.xml/Case.bi4 (see above)")
    ap.add_argument("--bench-exe", help="bench_dambreak (default: build*/bench/bench_dambreak)")
    ap.add_argument("--sizes", default="1e4,1e5", help="target fluid counts")
    ap.add_argument("--steps", default="200,50,10", help="timed steps per size (the last entry repeats)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed steps before the timed ones")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=2, help="runs per configuration; the fastest is kept")
    ap.add_argument("--wait-load", type=float, default=0.0,
                    help="before each size and thread count wait until the 1-minute load average is below this (0: off)")
    ap.add_argument("--wait-max", type=float, default=300.0, help="seconds to wait at most for --wait-load")
    ap.add_argument("--precision", default="double", help="sphdem precisions, comma list: double,mixed,single")
    ap.add_argument("--sphdem-extra", default="",
                    help="more bench_dambreak options, e.g. \"--tensile 0\" (DualSPHysics has no tensile correction)")
    ap.add_argument("--front-res", type=int, default=0, help="physics check at a/dx = R (0: off)")
    ap.add_argument("--front-T", type=float, default=2.0, help="physics check at T = t sqrt(2 g / a)")
    ap.add_argument("--front-threads", type=int, default=2)
    ap.add_argument("--workdir", help="DualSPHysics cases and outputs (default: a temporary directory, removed)")
    ap.add_argument("--out", default=os.path.join(HERE, "results_dsph"))
    args = ap.parse_args()

    dsph = check_peer(args.dsph_bin, "DualSPHysics CPU binary", "--dsph-bin")
    writer = check_peer(args.case_writer, "DualSPHysics case writer", "--case-writer")
    bench = find_bench(args.bench_exe)
    sizes = [float(s) for s in args.sizes.split(",") if s.strip()]
    steps_l = [int(s) for s in args.steps.split(",")]
    steps_l += [steps_l[-1]] * (len(sizes) - len(steps_l))
    threads = [int(t) for t in args.threads.split(",")]
    extra = args.sphdem_extra.split()
    precs = [p.strip() for p in args.precision.split(",") if p.strip()]
    workdir = args.workdir or tempfile.mkdtemp(prefix="dsph_compare_")
    os.makedirs(workdir, exist_ok=True)
    os.makedirs(args.out, exist_ok=True)

    la0 = os.getloadavg()
    stamp = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    log(f"# sphdem {git_commit()} vs DualSPHysics CPU, {os.cpu_count()} CPUs, {stamp}")
    log(f"# load average at start: {la0[0]:.2f} {la0[1]:.2f} {la0[2]:.2f}")
    log(f"# bench_dambreak: {bench}\n# DualSPHysics: {dsph}\n# case writer: {writer}\n# workdir: {workdir}")

    def pick(runs):
        ok = [r for r in runs if r.get("status") == "ok"]
        if not ok:
            return runs[-1]
        b = dict(max(ok, key=lambda r: r["psteps_per_s"]))
        b["all"] = [r["psteps_per_s"] for r in ok]
        b["loads"] = [r["load"] for r in runs]
        return b

    def wait_load():
        if args.wait_load <= 0:
            return
        t0 = time.monotonic()
        while os.getloadavg()[0] > args.wait_load and time.monotonic() - t0 < args.wait_max:
            time.sleep(10)
        if os.getloadavg()[0] > args.wait_load:
            log(f"# load {os.getloadavg()[0]:.2f} still above {args.wait_load} after {args.wait_max:.0f} s: running anyway")

    rows, skipped = [], []
    for n, st in zip(sizes, steps_l):
        cdir, meta = write_case(bench, writer, n, 0, args.warmup, st, workdir, f"n{int(n)}", extra)
        nf, nw = int(meta["nfluid"]), int(meta["nwall"])
        for th in threads:
            wait_load()
            # the repeats interleave the two codes, so that both see the same changes of the machine's load
            dr, sr = [], {p: [] for p in precs}
            for _ in range(max(1, args.repeat)):
                dr.append(dsph_run(dsph, cdir, meta, st, th, os.path.join(cdir, f"out_t{th}")))
                for p in precs:
                    if p in skipped:
                        continue
                    r = sphdem_run(bench, n, 0, st, args.warmup, th, p, extra)
                    if r["status"] == "rejected":
                        skipped.append(p)
                        log(f"# bench_dambreak rejects --precision {p}: skipped")
                        continue
                    sr[p].append(r)
            rd = pick(dr)
            if rd["status"] != "ok":
                log(f"DualSPHysics n={nf} threads={th}: {rd['status']}\n{rd.get('error', '')}")
            else:
                log(f"DualSPHysics n={nf:>8} threads={th} steps={st}: {rd['psteps_per_s'] / 1e6:.3f} M p-steps/s "
                    f"(runs {[round(x / 1e6, 3) for x in rd['all']]}, loads {[round(x, 2) for x in rd['loads']]}, "
                    f"excluded {rd['excluded']})")
            for p in precs:
                if not sr[p]:
                    continue
                rs = pick(sr[p])
                if rs["status"] != "ok":
                    log(f"sphdem n={n:g} threads={th} precision={p}: {rs['status']}\n{rs.get('error', '')}")
                    continue
                log(f"sphdem       n={rs['nfluid']:>8} threads={th} steps={st} precision={p}: "
                    f"{rs['psteps_per_s'] / 1e6:.3f} M p-steps/s (runs {[round(x / 1e6, 3) for x in rs['all']]}, "
                    f"loads {[round(x, 2) for x in rs['loads']]})")
                rows.append(dict(n_target=n, nfluid=nf, nwall=nw, threads=th, steps=st, precision=p, s=rs,
                                 d=rd if rd["status"] == "ok" else None))
        if not args.workdir:
            shutil.rmtree(cdir, ignore_errors=True)

    la1 = os.getloadavg()
    # linear fits of time per step against N
    fits = []
    for p in precs:
        for th in threads:
            sel = [r for r in rows if r["threads"] == th and r["precision"] == p]
            if len(sel) < 2:
                continue
            ns = [r["nfluid"] for r in sel]
            fits.append(("sphdem", p, th) + linfit(ns, [r["s"]["t_step"] for r in sel]) + (len(sel),))
            if p == precs[0] and all(r["d"] for r in sel):
                fits.append(("DualSPHysics", "single/double-pos", th) + linfit(ns, [r["d"]["t_step"] for r in sel])
                            + (len(sel),))

    front = None
    if args.front_res > 0:
        a, g = 1.0, 9.81
        cdir, meta = write_case(bench, writer, 0, args.front_res, 1, 1, workdir, f"front_r{args.front_res}", extra)
        dt = float(meta["dt"])
        k = int(round(args.front_T / math.sqrt(2 * g / a) / dt))
        shutil.rmtree(cdir)
        cdir, meta = write_case(bench, writer, 0, args.front_res, 1, k - 1, workdir, f"front_r{args.front_res}", extra)
        rs = sphdem_run(bench, 0, args.front_res, k, 0, args.front_threads, "double", extra)
        od = os.path.join(cdir, "out")
        rd = dsph_run(dsph, cdir, meta, k - 1, args.front_threads, od, svcsv=True)
        fd, fn = dsph_front(od, int(meta["nwall"])) if rd["status"] == "ok" else (float("nan"), None)
        fs = float(rs.get("front", "nan"))
        front = dict(res=args.front_res, nfluid=int(meta["nfluid"]), steps=k, t=k * dt, T=k * dt * math.sqrt(2 * g / a),
                     sphdem=fs, dsph=fd, dev=(fs / fd - 1) if fd == fd and fd else float("nan"),
                     dsph_excluded=rd.get("excluded"))
        log(f"# front check a/dx={args.front_res} ({front['nfluid']} fluid), {k} steps of dt={dt:.6e}: t={front['t']:.4f} s, "
            f"T=t sqrt(2g/a)={front['T']:.3f}: sphdem {fs:.4f} a, DualSPHysics {fd:.4f} a, "
            f"sphdem/DualSPHysics - 1 = {100 * front['dev']:+.2f}%")
        if not args.workdir:
            shutil.rmtree(cdir, ignore_errors=True)
    if not args.workdir:
        shutil.rmtree(workdir, ignore_errors=True)

    # table
    head = "| N fluid | N wall | threads | steps | sphdem precision | sphdem M p-steps/s | DualSPHysics M p-steps/s | ratio sphdem/DSPH | load (1 min) |"
    md = [f"load average: start {la0[0]:.2f} {la0[1]:.2f} {la0[2]:.2f}, end {la1[0]:.2f} {la1[1]:.2f} {la1[2]:.2f} "
          f"({os.cpu_count()} CPUs)", "", head, "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        sd = r["s"]["psteps_per_s"]
        dd = r["d"]["psteps_per_s"] if r["d"] else float("nan")
        loads = r["s"]["loads"] + (r["d"]["loads"] if r["d"] else [])
        md.append(f"| {r['nfluid']:,} | {r['nwall']:,} | {r['threads']} | {r['steps']} | {r['precision']} | {m(sd)} | "
                  f"{m(dd)} | {sd / dd:.2f} | {min(loads):.2f}-{max(loads):.2f} |")
    md += ["", "time per step t = t0 + b N (least squares over the sizes above):", "",
           "| code | precision | threads | t0 (ms) | b (ns per fluid particle) | R^2 | sizes |", "|---|---|---|---|---|---|---|"]
    for code, p, th, t0, b, r2, k in fits:
        md.append(f"| {code} | {p} | {th} | {1e3 * t0:.3f} | {1e9 * b:.1f} | {r2:.5f} | {k} |")
    if front:
        md += ["", f"front check (a/dx = {front['res']}, {front['nfluid']} fluid, {front['steps']} steps, t = {front['t']:.4f} s, "
               f"T = t sqrt(2g/a) = {front['T']:.3f}): sphdem {front['sphdem']:.4f} a, DualSPHysics {front['dsph']:.4f} a, "
               f"difference {100 * front['dev']:+.2f}% (DualSPHysics excluded particles: {front['dsph_excluded']})"]
    if skipped:
        md += ["", "bench_dambreak rejected --precision " + ", ".join(skipped) + " (skipped)"]
    log("")
    for l in md:
        log(l)
    with open(os.path.join(args.out, "results.md"), "w") as f:
        f.write(f"# sphdem vs DualSPHysics CPU, 2D dam break ({stamp}, sphdem {git_commit()})\n\n")
        f.write("\n".join(md) + "\n\ncommand: `" + " ".join(sys.argv) + "`\n")
    with open(os.path.join(args.out, "results.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["nfluid", "nwall", "threads", "steps", "precision", "sphdem_psteps_per_s", "dsph_psteps_per_s", "ratio",
                    "sphdem_t_step_s", "dsph_t_step_s", "dsph_sim_runtime_per_step_s", "sphdem_load", "dsph_load",
                    "dsph_excluded", "sphdem_runs", "dsph_runs"])
        for r in rows:
            d = r["d"] or {}
            sd, dd = r["s"]["psteps_per_s"], d.get("psteps_per_s", float("nan"))
            w.writerow([r["nfluid"], r["nwall"], r["threads"], r["steps"], r["precision"], f"{sd:.6e}", f"{dd:.6e}",
                        f"{sd / dd:.4f}", f"{r['s']['t_step']:.6e}", f"{d.get('t_step', float('nan')):.6e}",
                        f"{d['sim_runtime'] / d['nstep_total']:.6e}" if d else "",
                        f"{r['s']['load']:.2f}", f"{d.get('load', float('nan')):.2f}", d.get("excluded", ""),
                        " ".join(f"{x:.4e}" for x in r["s"]["all"]), " ".join(f"{x:.4e}" for x in d.get("all", []))])
    log(f"\n# wrote {os.path.join(args.out, 'results.md')} and results.csv")


if __name__ == "__main__":
    main()
