#!/usr/bin/python3
"""Study 8 (scripts/studies 8): a map that holds part of the route, queries that run past it.

Each case cuts the reference sets of a real pair or triple of traversals to a stretch of
the route and queries with all of another traversal, so that some queries show no place of
the map. It runs bsf_evaluate three times: the default (off_map true) and the belief of
2026-12-05 (off_map false) on all the queries, and that belief on the on-map queries alone
(what the same map gave for the queries it holds). Printed per case and method: those AUCs
(recall over the on-map queries), how many off-map queries had a match accepted at the
default threshold, and the AUC given up against the on-map queries alone with its 95%
interval from a block bootstrap (blocks of 10 consecutive queries, 1000 draws, seeded).
A fourth run applies the map's own rule (--max-false-accept-rate 0.01, the map calibrated
on its own traversals): the off-map queries it accepts, the rate the map predicted, and the
right matches accepted by the default and by the rule.
The blind cases are real frames as four blind cameras see them (bsf_make_views --blind:
covered, grey, black, dazzled; 100 each): every query is off the map. They print the
acceptances of the descriptors alone (the frames' descriptors as a .npy: no image check)
-> of the image folder (the image check: a blind frame is no observation), per kind for
the first. Usage: study_offmap.py OUT_DIR [CASE ...]
"""
import csv
import glob
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from study_regret import auc_of as auc  # noqa: E402  bsf_evaluate's AUC

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(REPO, "data")
N100 = os.path.join(DATA, "nordland_subset100")
GP = os.path.join(DATA, "gardens_point_hdc_delf")
COR = os.path.join(DATA, "vprbench_corridor")
METHODS = ["bsf", "bsf+filter"]
BLIND_KINDS = ["covered", "grey", "black", "dazzled"]


def tool(name, *args):
    r = subprocess.run(["rosrun", "bsf_vpr", name] + list(args), stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.exit("study_offmap: %s failed:\n%s" % (name, r.stdout[-2000:]))
    return r.stdout


def link_images(files, folder):
    os.makedirs(folder, exist_ok=True)
    for k, f in enumerate(files):
        link = os.path.join(folder, "%05d%s" % (k, os.path.splitext(f)[1]))
        if not os.path.lexists(link):
            os.symlink(f, link)
    return folder


def images(folder):
    return sorted(glob.glob(os.path.join(folder, "*")))


def write_truth(path, correct):
    with open(path, "w") as f:
        f.write("query,correct_places\n")
        for q, places in enumerate(correct):
            f.write("%d,%s\n" % (q, " ".join(map(str, places))))


def aligned_truth(queries, places, tolerance):
    """Frame q of the query traversal shows frame q: its correct places are the map's places
    (indices into `places`, frames of the reference traversals) within `tolerance` frames."""
    at = {frame: k for k, frame in enumerate(places)}
    return [[at[f] for f in range(q - tolerance, q + tolerance + 1) if f in at] for q in queries]


class Case:
    """Inputs of one case: its map and queries (all, and on-map alone) as bsf_evaluate args,
    and the correct places of every query."""

    def __init__(self, name, design):
        self.name, self.design = name, design


def frames_case(out, name, design, refs, query_folder, places, tolerance, extra=()):
    c = Case(name, design)
    d = os.path.join(out, "inputs", name)
    c.refs = []
    for set_name, folder in refs:
        files = images(folder)
        c.refs += ["--reference", "%s=%s" % (
            set_name, link_images([files[i] for i in places], os.path.join(d, set_name)))]
    qf = images(query_folder)
    c.truth = aligned_truth(range(len(qf)), places, tolerance)
    on = [q for q in range(len(qf)) if c.truth[q]]  # the queries the map holds a place of
    c.query = link_images(qf, os.path.join(d, "query"))
    c.query_on = link_images([qf[q] for q in on], os.path.join(d, "query_on"))
    c.truth_on = [c.truth[q] for q in on]
    c.on_index = on
    c.extra = list(extra)
    return c


def npy_case(out, name, design, refs, query_npy, places, tolerance, extra=()):
    c = Case(name, design)
    d = os.path.join(out, "inputs", name)
    os.makedirs(d, exist_ok=True)
    c.refs = []
    for set_name, path in refs:
        np.save(os.path.join(d, set_name + ".npy"), np.load(path)[places])
        c.refs += ["--reference", "%s=%s" % (set_name, os.path.join(d, set_name + ".npy"))]
    q = np.load(query_npy)
    c.truth = aligned_truth(range(len(q)), places, tolerance)
    on = [i for i in range(len(q)) if c.truth[i]]  # the queries the map holds a place of
    c.query, c.query_on = os.path.join(d, "query.npy"), os.path.join(d, "query_on.npy")
    np.save(c.query, q)
    np.save(c.query_on, q[on])
    c.truth_on = [c.truth[i] for i in on]
    c.on_index = on
    c.extra = list(extra)
    return c


def corridor_case(out, name, design, keep):
    """The Corridor's 10 techniques as sources, the map cut to reference places 0..keep-1."""
    c = Case(name, design)
    d = os.path.join(out, "inputs", name)
    os.makedirs(d, exist_ok=True)
    truth = [[int(p) for p in r["correct_places"].split()]
             for r in csv.DictReader(open(os.path.join(COR, "ground_truth.csv")))]
    c.truth = [[p for p in t if p < keep] for t in truth]
    on = [q for q, t in enumerate(c.truth) if t]
    c.refs, c.query, c.query_on = [], None, None
    c.sources, c.sources_on = [], []
    for path in sorted(glob.glob(os.path.join(COR, "*.npy"))):
        s = np.load(path)[:, :keep]
        tech = os.path.splitext(os.path.basename(path))[0]
        np.save(os.path.join(d, tech + ".npy"), s)
        np.save(os.path.join(d, tech + "_on.npy"), s[on])
        c.sources += ["--similarities", "%s=%s" % (tech, os.path.join(d, tech + ".npy"))]
        c.sources_on += ["--similarities", "%s=%s" % (tech, os.path.join(d, tech + "_on.npy"))]
    c.truth_on = [c.truth[q] for q in on]
    c.on_index = on
    c.extra = []
    return c


def evaluate(c, out, which):
    d = os.path.join(out, c.name, which)
    truth = os.path.join(out, "inputs", c.name, "truth%s.csv" % ("_on" if which == "alone" else ""))
    write_truth(truth, c.truth_on if which == "alone" else c.truth)
    if c.query is None:
        inputs = c.sources_on if which == "alone" else c.sources
    elif which == "descriptors":
        inputs = c.refs + ["--query", c.query_descriptors]
    else:
        inputs = c.refs + ["--query", c.query_on if which == "alone" else c.query]
    args = inputs + ["--ground-truth", truth, "--methods", ",".join(METHODS), "--no-progress",
                     "--out", d] + c.extra
    if which not in ("new", "calibrated", "descriptors"):
        args += ["--off-map", "false"]
    if which == "calibrated":
        args += ["--max-false-accept-rate", "0.01"]
    out_text = tool("bsf_evaluate", *args)
    with open(os.path.join(d, "stdout.txt"), "w") as f:
        f.write(out_text)
    return d


def predicted(d, method):
    """The rate the map predicted for `method` ("on this map (...): false acceptances x%"),
    with '(1 set)' where it was measured but not applied, '-' where it could not calibrate."""
    for line in open(os.path.join(d, "stdout.txt")):
        if "on this map (%s):" % method in line:
            if "false acceptances" not in line:
                return "-"
            rate = line.split("false acceptances ")[1].split("%")[0] + "%"
            return rate + (" (1 set)" if "not applied" in line else "")
        if "not calibrated" in line:
            return "-"
    return "-"


def right_accepted(d, method, truth):
    rows = list(csv.DictReader(open(os.path.join(d, "matches", method.replace(":", "_") + ".csv"))))
    return sum(1 for q, r in enumerate(rows) if r["accepted"] == "1" and int(r["match"]) in truth[q])


def outcomes(d, method, truth):
    rows = list(csv.DictReader(open(os.path.join(d, "matches", method.replace(":", "_") + ".csv"))))
    conf = np.array([float(r["confidence"]) for r in rows])
    ok = np.array([int(r["match"]) in truth[q] for q, r in enumerate(rows)])
    accepted = np.array([r["accepted"] == "1" for r in rows])
    return conf, ok, accepted


def given_up(alone, new, on_index, has_truth, block=10, draws=1000, seed=0):
    """AUC(on-map alone) - AUC(new), and its block-bootstrap interval over the query order."""
    (ca, oka), (cn, okn) = alone, new
    q = len(cn)
    pos = {query: k for k, query in enumerate(on_index)}
    starts = np.arange(0, q, block)
    rng = np.random.default_rng(seed)
    diffs = []
    for _ in range(draws):
        picked = np.concatenate([np.arange(s, min(s + block, q)) for s in rng.choice(starts, len(starts))])
        on = [pos[x] for x in picked if x in pos]
        n_true = int(sum(has_truth[x] for x in picked))
        if not on or n_true == 0:
            continue
        diffs.append(auc(ca[on], oka[on], n_true) - auc(cn[picked], okn[picked], n_true))
    n_true = int(sum(has_truth))
    point = auc(ca, oka, n_true) - auc(cn, okn, n_true)
    return point, np.percentile(diffs, 2.5), np.percentile(diffs, 97.5)


def blind_case(out, name, frames, refs):
    """The frames as four blind cameras see them (bsf_make_views --blind covered, grey,
    black, dazzled): 4 x 100 queries, none on the map. The query is the image folder (the
    image check applies: no observation) or, for the "descriptors" run, its descriptors
    alone (bsf_make_reference), what the methods make of those frames without the check."""
    d = os.path.join(out, "inputs", name)
    files = []
    for kind in BLIND_KINDS:
        tool("bsf_make_views", "--images", frames, "--out", os.path.join(d, kind), "--crop", "1",
             "--blind", kind)
        files += images(os.path.join(d, kind))
    c = Case(name, False)
    c.refs = []
    for set_name, folder in refs:
        c.refs += ["--reference", "%s=%s" % (set_name, folder)]
    c.query = link_images(files, os.path.join(d, "query"))
    c.query_descriptors = os.path.join(d, "query.yaml")
    tool("bsf_make_reference", "--images", c.query, "--name", "query", "--out",
         c.query_descriptors)
    c.truth = [[] for _ in files]
    c.extra = ["--distance", "cosine"]
    return c


def main():
    out = sys.argv[1]
    only = set(sys.argv[2:])
    cases = []
    seasons = [("winter", "summer", "fall"), ("fall", "summer", "winter"), ("summer", "fall", "winter")]
    for q, a, b in seasons:
        cases.append(lambda q=q, a=a, b=b: frames_case(
            out, "n100_%s_map_0-49" % q, True,
            [(a, "%s/64x32/%s" % (N100, a)), (b, "%s/64x32/%s" % (N100, b))],
            "%s/64x32/%s" % (N100, q), list(range(50)), 2))
    cases.append(lambda: npy_case(out, "gardens_night_map_0-99", True,
                                  [("day", GP + "/day_left.npy")], GP + "/night_right.npy",
                                  list(range(100)), 8, ["--distance", "cosine"]))
    cases.append(lambda: frames_case(out, "nordland_summer_map_375-1124", True,
                                     [("winter", DATA + "/nordland_64x32/winter")],
                                     DATA + "/nordland_64x32/summer", list(range(375, 1125)), 2,
                                     ["--distance", "cosine"]))
    cases.append(lambda: frames_case(out, "nordland_winter_map_0-749", True,
                                     [("summer", DATA + "/nordland_64x32/summer")],
                                     DATA + "/nordland_64x32/winter", list(range(750)), 2,
                                     ["--distance", "cosine"]))
    for q, a, b in seasons:
        cases.append(lambda q=q, a=a, b=b: frames_case(
            out, "n100_256_%s_map_25-74" % q, False,
            [(a, "%s/256x144/%s" % (N100, a)), (b, "%s/256x144/%s" % (N100, b))],
            "%s/256x144/%s" % (N100, q), list(range(25, 75)), 2))
    cases.append(lambda: npy_case(out, "gardens_day_map_100-199", False,
                                  [("night", GP + "/night_right.npy")], GP + "/day_left.npy",
                                  list(range(100, 200)), 8, ["--distance", "cosine"]))
    cases.append(lambda: corridor_case(out, "corridor_map_0-55", False, 56))
    print("%-30s %-10s %6s  %8s %8s  %-14s %-24s | %s" % (
        "case (D: designed on)", "method", "alone", "2026-12-05", "default", "off-map accepted",
        "AUC given up [95%]", "calibrated 1%: off-map accepted, predicted; right accepted"))
    for make in cases:
        c = make()
        if only and c.name not in only:
            continue
        dirs = {w: evaluate(c, out, w) for w in ("alone", "today", "new", "calibrated")}
        has_truth = [bool(t) for t in c.truth]
        for m in METHODS:
            alone = outcomes(dirs["alone"], m, c.truth_on)
            today = outcomes(dirs["today"], m, c.truth)
            new = outcomes(dirs["new"], m, c.truth)
            off = ~np.array(has_truth)
            n_true = int(sum(has_truth))
            point, lo, hi = given_up(alone[:2], new[:2], c.on_index, has_truth)
            cal = outcomes(dirs["calibrated"], m, c.truth)
            print("%-30s %-10s %6.3f  %8.3f %8.3f  %3d -> %3d of %3d  %+.3f [%+.3f, %+.3f] | "
                  "%3d of %3d, %s; %d -> %d" % (
                      c.name + (" (D)" if c.design else ""), m,
                      auc(alone[0], alone[1], len(c.on_index)), auc(today[0], today[1], n_true),
                      auc(new[0], new[1], n_true), today[2][off].sum(), new[2][off].sum(),
                      off.sum(), point, lo, hi, cal[2][off].sum(), off.sum(),
                      predicted(dirs["calibrated"], m), right_accepted(dirs["new"], m, c.truth),
                      right_accepted(dirs["calibrated"], m, c.truth)), flush=True)
    for res in ("64x32", "256x144"):
        name = "blind_%s" % res
        if only and name not in only:
            continue
        c = blind_case(out, name, "%s/%s/winter" % (N100, res),
                       [(s, "%s/%s/%s" % (N100, res, s)) for s in ("summer", "fall")])
        for which in ("descriptors", "new", "calibrated"):
            evaluate(c, out, which)
        for m in METHODS:
            acc = {w: outcomes(os.path.join(out, name, w), m, c.truth)[2]
                   for w in ("descriptors", "new", "calibrated")}
            per_kind = ", ".join("%s %d" % (k, acc["descriptors"][100 * i:100 * (i + 1)].sum())
                                 for i, k in enumerate(BLIND_KINDS))
            print("%-30s %-10s %6s  %8s %8s  %3d -> %3d of %3d  %-24s | %3d of %3d, %s" % (
                name + ", blind camera", m, "", "", "", acc["descriptors"].sum(),
                acc["new"].sum(), len(c.truth), "(" + per_kind + ")", acc["calibrated"].sum(),
                len(c.truth), predicted(os.path.join(out, name, "calibrated"), m)), flush=True)


if __name__ == "__main__":
    main()
