"""The trees of fitted HistGradientBoosting models in flat arrays, walked by numpy.

scikit-learn walks its trees one Python call at a time: ~80 ms for the ~4500 trees of a
load-state model and one trace. Here all trees advance together one level per step (a few numpy
operations on arrays of one entry per tree), well under a millisecond. The estimators of
:mod:`signatelec.estimation.models` use it for a few rows at a time (:data:`SMALL_BATCH`);
tests check it against scikit-learn's own predictions.
"""

from __future__ import annotations

import numpy as np

#: Rows up to which predictions walk the flat forest rather than scikit-learn's trees.
SMALL_BATCH = 32


class FlatForest:
    """The trees of fitted HistGradientBoosting models, one output column per model and class.

    Reads the models' private tree records, so it is rebuilt at every fit and model files do
    not carry across scikit-learn releases anyway.
    """

    def __init__(self, models):
        feature, threshold, missing_left, left, right, leaf, value = ([] for _ in range(7))
        roots, outputs, baselines = [], [], []
        offset, out, depth = 0, 0, 0
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
                    depth = max(depth, int(nodes["depth"].max()))
            out += k
        cat = np.concatenate
        self.feature, self.threshold = cat(feature).astype(np.int64), cat(threshold)
        self.missing_left, self.leaf, self.value = cat(missing_left), cat(leaf), cat(value)
        self.left, self.right = cat(left), cat(right)
        self.roots, self.outputs = np.asarray(roots), np.asarray(outputs)
        self.baseline = cat(baselines)
        self.n_outputs = out
        self.depth = depth

    def raw(self, X: np.ndarray) -> np.ndarray:
        """Raw predictions (before the link), shape (n_samples, n_outputs)."""
        node = np.broadcast_to(self.roots, (X.shape[0], self.roots.size)).copy()
        rows = np.arange(X.shape[0])[:, None]
        for _ in range(self.depth):
            x = X[rows, self.feature[node]]
            go_left = np.where(np.isnan(x), self.missing_left[node], x <= self.threshold[node])
            node = np.where(
                self.leaf[node], node, np.where(go_left, self.left[node], self.right[node])
            )
        out = np.zeros((X.shape[0], self.n_outputs))
        for i in range(X.shape[0]):
            out[i] = np.bincount(
                self.outputs, weights=self.value[node[i]], minlength=self.n_outputs
            )
        return out + self.baseline
