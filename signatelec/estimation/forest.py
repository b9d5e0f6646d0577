"""The trees of fitted HistGradientBoosting models in flat arrays, walked by a compiled loop.

scikit-learn walks its trees one Python call per tree: ~80 ms for the ~4500 trees of a
load-state model and one trace, ~50 ms for 1000 rows of a monitored trace. Here one compiled
loop walks every tree for each row (a few ms), summing as scikit-learn does (the model's
baseline, then each tree's leaf in the order of the iterations): the same bits. The estimators
of :mod:`signatelec.estimation.models` predict with it; tests check it against
scikit-learn's own predictions.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def _walk(x, feature, threshold, missing_left, left, right, leaf, value, roots, outputs, baseline):
    """Raw predictions of the rows of ``x``: per output, the baseline plus the leaf value of
    each of its trees, added in order (scikit-learn's ``_raw_predict``: the same bits). A
    missing value (NaN) goes where the tree sends missing values."""
    out = np.empty((x.shape[0], baseline.size))
    for i in range(x.shape[0]):
        for k in range(baseline.size):
            out[i, k] = baseline[k]
    # tree by tree (its nodes stay in the cache), each row's sum still in the trees' order
    for t in range(roots.size):
        k = outputs[t]
        for i in range(x.shape[0]):
            node = roots[t]
            while not leaf[node]:
                v = x[i, feature[node]]
                go_left = missing_left[node] if np.isnan(v) else v <= threshold[node]
                node = left[node] if go_left else right[node]
            out[i, k] += value[node]
    return out


class FlatForest:
    """The trees of fitted HistGradientBoosting models, one output column per model and class.

    Reads the models' private tree records, so it is rebuilt at every fit and model files do
    not carry across scikit-learn releases anyway.
    """

    def __init__(self, models):
        feature, threshold, missing_left, left, right, leaf, value = ([] for _ in range(7))
        roots, outputs, baselines = [], [], []
        offset, out = 0, 0
        for m in models:
            k = m.n_trees_per_iteration_
            baselines.append(np.asarray(m._baseline_prediction, dtype=float).ravel())
            for iteration in m._predictors:
                for j, predictor in enumerate(iteration):
                    nodes = predictor.nodes
                    if np.any(nodes["is_categorical"]):
                        raise ValueError("categorical splits are not supported")
                    roots.append(offset)
                    outputs.append(out + j)
                    feature.append(nodes["feature_idx"])
                    threshold.append(nodes["num_threshold"])
                    missing_left.append(nodes["missing_go_to_left"].astype(bool))
                    left.append(nodes["left"].astype(np.int64) + offset)
                    right.append(nodes["right"].astype(np.int64) + offset)
                    leaf.append(nodes["is_leaf"].astype(bool))
                    value.append(nodes["value"])
                    offset += len(nodes)
            out += k
        cat = np.concatenate
        self.feature, self.threshold = cat(feature).astype(np.int64), cat(threshold)
        self.missing_left, self.leaf, self.value = cat(missing_left), cat(leaf), cat(value)
        self.left, self.right = cat(left), cat(right)
        self.roots, self.outputs = np.asarray(roots), np.asarray(outputs)
        self.baseline = cat(baselines)

    def raw(self, X: np.ndarray) -> np.ndarray:
        """Raw predictions (before the link), one column per model and class."""
        return _walk(
            np.ascontiguousarray(X, dtype=np.float64),
            self.feature,
            self.threshold,
            self.missing_left,
            self.left,
            self.right,
            self.leaf,
            self.value,
            self.roots,
            self.outputs,
            self.baseline,
        )
