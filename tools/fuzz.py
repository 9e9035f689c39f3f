"""Fuzz campaigns against texray's contract (issue 12): nothing crashes, hangs, returns NaN
or raises anything but a texray error; scene-file errors name the file.

    python tools/fuzz.py --cases 300 [--seed S] [--workers 1] [--timeout 60] [--out DIR]
    python tools/fuzz.py --seed S --case K          # replay one case: print its program and run it
    python tools/fuzz.py --seed S --case K --show   # only print the program

Case K of campaign S is determined by (S, K) alone (tests/fuzz_cases.py), so the replay
runs exactly the input of the campaign. Cases run in persistent worker processes (one per
--workers slot), each restarted after a crash or a hang so that either is attributed to the
case that was running; every case has --timeout seconds of wall clock (the first one also
builds the OpenCL program, cached by PoCL on disk afterwards).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import threading
import time
from collections import Counter, defaultdict
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import fuzz_cases as fc  # noqa: E402


def _reproducer(seed, k, family):
    return f"python tools/fuzz.py --seed {seed} --case {k}" + (f" --family {family}" if family else "")


def run_campaign(seed, ks, workers, timeout, family=None, verbose=True):
    """[(k, case, outcome)] for the case numbers ``ks``."""
    results = {}
    todo = list(ks)
    lock = threading.Lock()
    t_start = time.perf_counter()

    def slot(i):
        with fc.Worker() as w:
            while True:
                with lock:
                    if not todo:
                        return
                    k = todo.pop(0)
                try:
                    case = fc.campaign_case(seed, k, family)
                except Exception as e:               # a bug of the generators: report it, go on
                    import traceback
                    case = fc.Case(family or "?", f"# generation of case {k} failed\n", label=f"seed {seed} case {k}")
                    out = {"kind": "harness_error", "exc_type": type(e).__name__, "where": "generation",
                           "detail": f"{e} | {traceback.format_exc()[-800:]}", "seconds": 0.0}
                else:
                    out = w.run(case, timeout)
                with lock:
                    results[k] = (case, out)
                    if verbose:
                        done = len(results)
                        mark = "FINDING " if fc.is_finding(out) else ""
                        line = (f"[{done}/{len(ks)} {time.perf_counter() - t_start:7.1f}s] case {k:5d} "
                                f"{case.family:12s} {out['seconds']:6.2f}s {mark}{out['kind']}")
                        if fc.is_finding(out):
                            line += f": {out.get('exc_type', '')} {out['detail'][:160]}"
                        print(line, flush=True)

    threads = [threading.Thread(target=slot, args=(i,), daemon=True) for i in range(workers)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    return [(k, *results[k]) for k in sorted(results)]


def summarize(seed, rows, family, wall):
    counts = Counter(out["kind"] for _, _, out in rows)
    secs = [out["seconds"] for _, _, out in rows]
    per_family = defaultdict(list)
    for _, case, out in rows:
        per_family[case.family].append(out["seconds"])
    groups = defaultdict(list)
    for k, case, out in rows:
        if fc.is_finding(out):
            groups[(case.family, fc.signature(out))].append((k, case, out))
    findings = []
    for (fam, sig), items in sorted(groups.items(), key=lambda kv: (-len(kv[1]), kv[0])):
        k, case, out = items[0]
        findings.append({"signature": sig, "family": fam, "count": len(items), "cases": [i[0] for i in items],
                         "kind": out["kind"], "exc_type": out.get("exc_type", ""), "where": out.get("where", ""),
                         "detail": out["detail"], "reproducer": _reproducer(seed, k, family),
                         "code": case.source(), "log": out.get("log", "")})
    return {
        "seed": seed, "family": family, "cases": len(rows), "wall_s": wall,
        "counts": {k: counts.get(k, 0) for k in fc.OK_KINDS + fc.FINDING_KINDS},
        "seconds": {"median": statistics.median(secs) if secs else 0, "total": sum(secs),
                    "max": max(secs) if secs else 0,
                    "per_family_median": {f: statistics.median(v) for f, v in sorted(per_family.items())}},
        "findings": findings,
        "outcomes": [{"case": k, "family": case.family, **{x: out.get(x) for x in ("kind", "exc_type", "where",
                                                                                    "detail", "seconds")}}
                     for k, case, out in rows],
    }


def print_summary(s):
    print(f"\n{s['cases']} cases, seed {s['seed']}, {s['wall_s']:.1f} s wall; per case: median "
          f"{s['seconds']['median']:.2f} s, total {s['seconds']['total']:.1f} s, max {s['seconds']['max']:.1f} s")
    print("per family (median s): " + ", ".join(f"{f} {v:.2f}" for f, v in s["seconds"]["per_family_median"].items()))
    ok = ", ".join(f"{k} {s['counts'][k]}" for k in fc.OK_KINDS)
    bad = ", ".join(f"{k} {s['counts'][k]}" for k in fc.FINDING_KINDS if s["counts"][k])
    print(f"outcomes: {ok}")
    print(f"findings: {bad or 'none'}")
    if s["findings"]:
        print(f"\n{len(s['findings'])} distinct findings (family | kind | exception | where):")
        for f in s["findings"]:
            print(f"  [{f['count']:3d}x] {f['family']} | {f['signature']}\n        {f['detail'][:200]}\n"
                  f"        reproduce: {f['reproducer']}")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=int, default=100, help="number of cases (0 .. N-1, after --start)")
    p.add_argument("--start", type=int, default=0, help="first case number")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--timeout", type=float, default=60.0, help="wall-clock seconds per case")
    p.add_argument("--case", type=int, action="append", help="run only this case (repeatable)")
    p.add_argument("--family", choices=sorted(fc.FAMILIES), help="only cases of this family")
    p.add_argument("--show", action="store_true", help="print the cases' programs, run nothing")
    p.add_argument("--out", help="directory for summary.json and findings.md")
    p.add_argument("-q", "--quiet", action="store_true")
    a = p.parse_args(argv)
    ks = a.case if a.case else list(range(a.start, a.start + a.cases))
    if a.show or a.case:
        for k in ks:
            print(fc.campaign_case(a.seed, k, a.family).source())
        if a.show:
            return 0
    t0 = time.perf_counter()
    rows = run_campaign(a.seed, ks, max(1, a.workers), a.timeout, a.family, verbose=not a.quiet)
    s = summarize(a.seed, rows, a.family, time.perf_counter() - t0)
    if a.case:
        for k, case, out in rows:
            print(f"case {k}: {out['kind']} {out.get('exc_type', '')} {out.get('where', '')}\n  {out['detail']}")
            if out.get("log"):
                print("  worker log:\n" + "\n".join("    " + line for line in out["log"].splitlines()[-40:]))
    else:
        print_summary(s)
    if a.out:
        out = Path(a.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").write_text(json.dumps(s, indent=1, default=str))
        with open(out / "findings.md", "w") as f:
            for x in s["findings"]:
                f.write(f"## [{x['count']}x] {x['family']}: {x['signature']}\n\n{x['detail']}\n\n"
                        f"Reproduce: `{x['reproducer']}` (cases {x['cases'][:20]})\n\n```python\n{x['code']}```\n\n")
        print(f"\nwrote {out / 'summary.json'} and {out / 'findings.md'}")
    return 1 if any(fc.is_finding(o) for _, _, o in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
