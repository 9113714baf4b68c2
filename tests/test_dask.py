"""GridSearchCV over HybridRegressor on a Dask cluster (joblib's dask backend, loopback only)."""

import cloudpickle
import distributed
import joblib
import numpy as np
from sklearn.model_selection import GridSearchCV

from sklearn_hybrid import HybridRegressor, make_theta_scorer
from sklearn_hybrid.models import pendulum_f


def test_gridsearch_on_dask_matches_local():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (8, 2))
    y = np.stack([X * np.cos(0.5 * t) for t in range(1, 4)], axis=1)
    est = HybridRegressor(science=pendulum_f, method="fsam", dt=0.1, n_substeps=1, max_iter=3,
                          residual={"hidden": (8,)}, random_state=0)
    grid = {"rho": [0.01, 0.1]}
    scorer = make_theta_scorer({"omega": 2 / 3})
    # what a remote worker receives: the estimator travels by pickle
    assert cloudpickle.loads(cloudpickle.dumps(est)).get_params()["rho"] == est.rho
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster):
        with joblib.parallel_backend("dask"):
            remote = GridSearchCV(est, grid, cv=2, scoring=scorer).fit(X, y)
    local = GridSearchCV(est, grid, cv=2, scoring=scorer).fit(X, y)
    np.testing.assert_allclose(remote.cv_results_["mean_test_score"],
                               local.cv_results_["mean_test_score"], rtol=1e-6)
    assert remote.best_params_ == local.best_params_
