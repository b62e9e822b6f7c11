"""Regrets of Study 7 (scripts/studies) with their uncertainty over a case's queries.

A case's regret is the best alternative's AUC minus the default's; its 95% interval comes
from a block bootstrap: the queries are cut into blocks of `block` consecutive ones and
resampled block by block (the temporal filter and the adaptive fusion make neighbouring
queries dependent, so resampling single queries would understate the spread). Seeded.
"""
import csv

import numpy as np


def load_matches(path):
    """(confidence, correct-within-tolerance is decided later): query, match, confidence."""
    rows = list(csv.DictReader(open(path)))
    return (np.array([int(r["query"]) for r in rows]), np.array([int(r["match"]) for r in rows]),
            np.array([float(r["confidence"]) for r in rows]))


def auc_of(confidence, correct, n_true):
    """Area under precision-recall as bsf_evaluate computes it (ties accepted together), with
    recall over `n_true` queries."""
    order = np.argsort(-confidence, kind="stable")
    c, ok = confidence[order], correct[order]
    area, precision, recall, accepted, hits, i = 0.0, 1.0, 0.0, 0, 0, 0
    while i < len(c):
        v = c[i]
        while i < len(c) and c[i] == v:
            accepted += 1
            hits += int(ok[i])
            i += 1
        p, r = hits / accepted, hits / n_true
        area += (r - recall) * 0.5 * (p + precision)
        precision, recall = p, r
    return area


def auc(query, match, confidence, tolerance=2):
    """The same where every query has a true match: query q shows place q, +-tolerance."""
    return auc_of(confidence, np.abs(match - query) <= tolerance, len(confidence))


def block_regret(default, best, tolerance, block=10, draws=1000, seed=0):
    """The regret AUC(best) - AUC(default) and its 95% block-bootstrap interval."""
    rng = np.random.default_rng(seed)
    q = len(default[0])
    block = min(block, q)
    starts_max = q - block + 1
    blocks = (q + block - 1) // block
    diffs = np.empty(draws)
    for k in range(draws):
        starts = rng.integers(0, starts_max, blocks)
        idx = np.concatenate([np.arange(s, s + block) for s in starts])[:q]
        diffs[k] = (auc(best[0][idx], best[1][idx], best[2][idx], tolerance) -
                    auc(default[0][idx], default[1][idx], default[2][idx], tolerance))
    regret = auc(*best, tolerance) - auc(*default, tolerance)
    return regret, float(np.percentile(diffs, 2.5)), float(np.percentile(diffs, 97.5))
