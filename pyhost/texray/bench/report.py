"""The benchmark's outputs: the terminal table, the markdown report, and
``--compare A.json B.json`` (ratios between two runs: devices, commits, settings)."""
from __future__ import annotations

import json
from pathlib import Path

STAGES = ("raygen", "intersect", "surface", "shadow", "shade")


def _ms(x):
    return f"{1e3 * x:.1f}"


def _spread_ms(s):
    return f"{_ms(s['median'])} ({_ms(s['min'])}-{_ms(s['max'])})"


def _mib(b):
    return f"{b / 2**20:.1f}"


def scene_rows(dev):
    """Rows (one per suite scene) of the main table, as lists of strings."""
    rows = []
    for name, r in dev.get("scenes", {}).items():
        sp = r["specialized"]
        gen = r.get("generic")
        b = dev.get("builds", {}).get(name, {})
        bs, bg = b.get("specialized"), b.get("generic")
        stg = r.get("stages", sp)
        st = stg["stage_mrays_s"]
        rows.append([
            name, f"{r['width']}x{r['height']}", str(r["spp"]), _spread_ms(sp["frame_s"]),
            _spread_ms(stg["frame_s"]) if "stages" in r else "-",
            _spread_ms(gen["frame_s"]) if gen else "-",
            f"{r['generic_over_specialized']:.2f}" if gen else "-",
            " / ".join(f"{st[k]:.1f}" if st.get(k) else "-" for k in STAGES),
            f"{bs['cold_s']:.2f} / {bs['warm_s']:.2f}" if bs else "-",
            f"{bg['cold_s']:.2f} / {bg['warm_s']:.2f}" if bg else "-",
            f"{_mib(sp['device_bytes'])} + {_mib(sp['ray_buffer_bytes'])}",
        ])
    return rows


SCENE_HEADER = ["scene", "size", "spp", "specialized ms (min-max)", "staged ms (min-max)", "generic ms (min-max)",
                "generic/spec.", "staged M/s per stage: " + " / ".join(STAGES), "build spec. cold/warm s", "build generic cold/warm s",
                "device MiB scene + rays"]


def _text_table(header, rows):
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    line = lambda cells: "  ".join(str(c).ljust(w) for c, w in zip(cells, widths))   # noqa: E731
    return "\n".join([line(header), line(["-" * w for w in widths])] + [line(r) for r in rows])


def _md_table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def sweep_rows(sw):
    """Rows of a sweep's table (:func:`sweep_header` names the columns)."""
    rows = []
    if sw.get("kind") == "displacement":
        for series, pts in sw["series"].items():
            for p in pts:
                mrays = sw["width"] * sw["height"] / p["render_s"]["median"] * 1e-6
                rows.append([series, p["label"], _spread_ms(p["frame_s"]), _spread_ms(p["render_s"]),
                             f"{mrays:.2f}", f"{p['device_mib']:.2f}", f"{p['rmse']:.4f}",
                             f"{100 * p['wrong_hit']:.2f}"])
        return rows
    for series, pts in sw["series"].items():
        for p in pts:
            rows.append([series, p["label"], _spread_ms(p["frame_s"]),
                         f"{p['mean_spp']:.1f}" if p.get("mean_spp") is not None else "-", f"{p['rmse']:.5f}",
                         f"{p['rel_rmse']:.4f}" if p.get("rel_rmse") is not None else "-",
                         f"{100 * p['bad_pixels']:.2f}"])
    return rows


SWEEP_HEADER = ["series", "setting", "frame ms (min-max)", "mean spp", "RMSE", "RMSE / mean", "% pixels off > 0.02"]
DISP_SWEEP_HEADER = ["series", "setting", "frame ms, setup included (min-max)", "render ms (min-max)",
                     "camera Mrays/s", "device MiB", "RMSE", "% wrong first hit"]


def sweep_header(sw):
    return DISP_SWEEP_HEADER if sw.get("kind") == "displacement" else SWEEP_HEADER


def sweep_title(scene, sw):
    """One line saying what a sweep compares against."""
    if sw.get("kind") == "displacement":
        return (f"{scene} {sw['width']}x{sw['height']}, 1 spp at pixel centres, against {sw['reference']} "
                f"({1e3 * sw['reference_s']:.0f} ms, {sw['reference_device_mib']:.2f} MiB)")
    return f"{scene} {sw['width']}x{sw['height']} against a {sw['ref_spp']}-spp reference"


def rays_line(rays):
    return (f"primary rays {rays['rays']} ({100 * rays['hit_fraction']:.0f}% hit): "
            f"{rays['primary_mrays_s']['median']:.2f} Mrays/s ({rays['primary_mrays_s']['min']:.2f}-"
            f"{rays['primary_mrays_s']['max']:.2f}); shadow rays {rays['shadow_rays']} "
            f"({100 * rays['shadow_occluded_fraction']:.0f}% occluded): {rays['shadow_mrays_s']['median']:.2f} "
            f"Mrays/s ({rays['shadow_mrays_s']['min']:.2f}-{rays['shadow_mrays_s']['max']:.2f})")


def print_device(name, dev, out):
    out.write(f"\n== {name}\n")
    if "rays" in dev:
        out.write("  " + rays_line(dev["rays"]) + "\n")
    if dev.get("scenes"):
        out.write("\n" + _text_table(SCENE_HEADER, scene_rows(dev)) + "\n")
    for scene, sw in dev.get("sweeps", {}).items():
        if sw.get("kind") == "displacement":
            out.write(f"\n  sweep {sweep_title(scene, sw)}\n")
        else:
            out.write(f"\n  sweep {scene} {sw['width']}x{sw['height']}, reference {sw['ref_spp']} spp "
                      f"({sw['reference_s']:.1f} s)\n")
        out.write(_text_table(sweep_header(sw), sweep_rows(sw)) + "\n")
    if dev.get("local_sizes"):
        ls = dev["local_sizes"]
        out.write("\n  local size (0 = driver's choice): "
                  + ", ".join(f"{k}: {_spread_ms(v)} ms" for k, v in ls["frame_s"].items())
                  + f"  [{ls['scene']} {ls['size']} {ls['spp']} spp]\n")
    if dev.get("peers"):
        for line in dev["peers"].get("lines", []):
            out.write("  " + line + "\n")


def markdown(results, plot_path=None) -> str:
    """The whole run as a markdown report."""
    r = results
    md = [f"# texray bench {r.get('date', '')}", "",
          f"texray {r['texray']} (commit {r.get('commit') or 'unknown'}) on {r['host']}; "
          f"`texray bench {' '.join(r['argv'])}`; medians of {r['repeat']} runs after a warm-up, (min-max).", ""]
    if "bvh" in r:
        b = r["bvh"]
        md += [f"BVH build (host, {b.get('builder', 'numpy')} builder): {b['triangles']} triangles in "
               f"{b['build_s']['median']:.2f} s, SAH cost {b['sah_cost']:.2f}, depth {b['depth']}"
               + (f"; numpy builder {b['numpy_build_s']['median']:.2f} s, SAH cost {b['numpy_sah_cost']:.2f}"
                  if "numpy_build_s" in b else "") + ".", ""]
    if r.get("variants") is not None:
        md += [f"Rendering every scene in `scenes/` builds {len(r['variants'])} program variants.", ""]
    for name, dev in r["devices"].items():
        md += [f"## {name}", ""]
        if "rays" in dev:
            md += [rays_line(dev["rays"]), ""]
        if dev.get("scenes"):
            md += [_md_table(SCENE_HEADER, scene_rows(dev)), "",
                   "Specialized and generic: the fused pipeline (one kernel per pixel); staged: the five "
                   "stage kernels, each timed alone. Stage M/s: camera samples per second through each stage "
                   "(shadow: shadow rays).", ""]
        for scene, sw in dev.get("sweeps", {}).items():
            md += [f"### Sweep: {sweep_title(scene, sw)}", "", _md_table(sweep_header(sw), sweep_rows(sw)), ""]
        if dev.get("local_sizes"):
            ls = dev["local_sizes"]
            md += [f"Work-group size ({ls['scene']} {ls['size']}, {ls['spp']} spp; 0 = driver's choice): "
                   + ", ".join(f"{k}: {_spread_ms(v)} ms" for k, v in ls["frame_s"].items()), ""]
        if dev.get("peers"):
            md += [f"- {line}" for line in dev["peers"].get("lines", [])] + [""]
    if plot_path:
        md += [f"![error against time]({plot_path})", ""]
    return "\n".join(md)


def _metrics(dev):
    """Flat {metric name: (value, higher_is_better)} of one device's results."""
    m = {}
    if "rays" in dev:
        m["primary Mrays/s"] = (dev["rays"]["primary_mrays_s"]["median"], True)
        m["shadow Mrays/s"] = (dev["rays"]["shadow_mrays_s"]["median"], True)
    for name, r in dev.get("scenes", {}).items():
        m[f"{name} frame ms"] = (1e3 * r["specialized"]["frame_s"]["median"], False)
        if r.get("generic"):
            m[f"{name} generic frame ms"] = (1e3 * r["generic"]["frame_s"]["median"], False)
        if r.get("stages"):
            m[f"{name} staged frame ms"] = (1e3 * r["stages"]["frame_s"]["median"], False)
        for k in STAGES:
            s = r.get("stages", r["specialized"])["stage_s"].get(k)
            if s and s["median"] > 0:
                m[f"{name} {k} ms"] = (1e3 * s["median"], False)
    for name, b in dev.get("builds", {}).items():
        for v, bt in b.items():
            m[f"{name} build {v} cold s"] = (bt["cold_s"], False)
            m[f"{name} build {v} warm s"] = (bt["warm_s"], False)
    for scene, sw in dev.get("sweeps", {}).items():
        for series, pts in sw["series"].items():
            for p in pts:
                m[f"{scene} {p['label']} ms"] = (1e3 * p["frame_s"]["median"], False)
                m[f"{scene} {p['label']} RMSE"] = (p["rmse"], False)
                if "wrong_hit" in p:
                    m[f"{scene} {p['label']} wrong first hit"] = (p["wrong_hit"], False)
    return m


def compare(path_a, path_b, out):
    """Print B/A ratios for every metric both runs have. Devices are paired by name,
    or, when each run has exactly one device, with each other."""
    a, b = (json.loads(Path(p).read_text()) for p in (path_a, path_b))
    da, db = a["devices"], b["devices"]
    pairs = [(n, n) for n in da if n in db]
    if not pairs and len(da) == 1 and len(db) == 1:
        pairs = [(next(iter(da)), next(iter(db)))]
    if not pairs:
        raise SystemExit(f"texray bench --compare: no device in common ({', '.join(da)} vs {', '.join(db)})")
    out.write(f"A: {path_a} (commit {a.get('commit')}, {a.get('host')})\n"
              f"B: {path_b} (commit {b.get('commit')}, {b.get('host')})\n")
    for na, nb in pairs:
        ma, mb = _metrics(da[na]), _metrics(db[nb])
        out.write(f"\n== {na}" + (f" vs {nb}" if nb != na else "") + "\n")
        rows = []
        for k, (va, better_high) in ma.items():
            if k not in mb or not va:
                continue
            vb = mb[k][0]
            ratio = vb / va
            good = ratio > 1 if better_high else ratio < 1
            rows.append([k, f"{va:.4g}", f"{vb:.4g}", f"{ratio:.3f}", "better" if good and abs(ratio - 1) > 0.05
                         else ("worse" if abs(ratio - 1) > 0.05 else "~")])
        out.write(_text_table(["metric", "A", "B", "B/A", ""], rows) + "\n")
    return 0
