"""SMT's MFK on the Forrester two-level pair, the reference of
src/stats/gp_two_level.rs's `the_forrester_pair_is_predicted_as_smt_mfk_predicts_it`.

Run: python3 -m venv v && v/bin/pip install smt==2.15.0 && v/bin/python tests/data/mfk_forrester_reference.py
"""
import numpy as np
from smt.applications.mfk import MFK

def hf(x): return (6 * x - 2) ** 2 * np.sin(12 * x - 4)
def lf(x): return 0.5 * hf(x) + 10 * (x - 0.5) - 5

xl = np.linspace(0, 1, 11).reshape(-1, 1)
xh = np.array([0.0, 0.4, 0.6, 1.0]).reshape(-1, 1)
sm = MFK(theta0=[1.0], corr="matern52", hyper_opt="Cobyla", print_global=False)
sm.set_training_values(xl, lf(xl), name=0)
sm.set_training_values(xh, hf(xh))
sm.train()
xt = np.array([0.05, 0.1, 0.2, 0.25, 0.3, 0.45, 0.5, 0.7, 0.8, 0.85, 0.9, 0.95]).reshape(-1, 1)
m = sm.predict_values(xt).ravel()
v = np.sqrt(np.maximum(sm.predict_variances(xt).ravel(), 0))
lfm = sm._predict_intermediate_values(xt, 1).ravel()
for x, a, b, c in zip(xt.ravel(), m, v, lfm):
    print(f"({x}, {a!r}, {b!r}, {c!r}),  # hf {hf(x)!r}")
