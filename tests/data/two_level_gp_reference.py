"""Closed-form reference of the two-level Gaussian process with fixed
hyperparameters (src/stats/gp_two_level.rs, tests in that module).

Run: python3 tests/data/two_level_gp_reference.py   (numpy only)
Prints rho, beta, their standard errors and the fine level's predictive mean
and latent sd at the probe points, to 17 significant digits.
"""
import numpy as np

def matern52(a, b, ls, var):
    r = np.sqrt((((a[:, None, :] - b[None, :, :]) / ls) ** 2).sum(-1))
    s = np.sqrt(5.0) * r
    return var * (1 + s + s * s / 3) * np.exp(-s)

xc = np.array([[0.05, 0.1], [0.2, 0.8], [0.35, 0.4], [0.5, 0.95],
               [0.6, 0.2], [0.75, 0.6], [0.9, 0.3], [0.98, 0.9]])
yc = np.sin(6 * xc[:, 0]) + xc[:, 1]
nc = np.full(8, 0.01)
xf = xc[[1, 3, 4, 6]]
yf = 1.8 * (np.sin(6 * xf[:, 0]) + xf[:, 1]) + 0.5 + 0.3 * xf[:, 0]
nf = np.array([0.02, 0.03, 0.02, 0.04])
probes = np.array([[0.1, 0.5], [0.5, 0.5], [0.8, 0.7]])

# coarse: simple kriging with the given constant mean
cv, cl, cn, cm = 1.2, np.array([0.3, 0.6]), 1e-6, 0.4
Kc = matern52(xc, xc, cl, cv) + np.diag(nc + cn)
ac = np.linalg.solve(Kc, yc - cm)
def coarse(x):
    k = matern52(x, xc, cl, cv)
    mean = cm + k @ ac
    var = np.maximum(cv - np.einsum('ij,ji->i', k, np.linalg.solve(Kc, k.T)), 0)
    return mean, var

# fine: universal kriging on f(x) = (mu_coarse(x), 1)
dv, dl, dn = 0.5, np.array([0.4, 0.8]), 1e-5
Kd = matern52(xf, xf, dl, dv) + np.diag(nf + dn)
F = np.column_stack([coarse(xf)[0], np.ones(len(xf))])
A = F.T @ np.linalg.solve(Kd, F)
Ainv = np.linalg.inv(A)
b = Ainv @ F.T @ np.linalg.solve(Kd, yf)
r = yf - F @ b
mc, vc = coarse(probes)
k = matern52(probes, xf, dl, dv)
mean = b[0] * mc + b[1] + k @ np.linalg.solve(Kd, r)
u = np.column_stack([mc, np.ones(len(probes))]) - (F.T @ np.linalg.solve(Kd, k.T)).T
var = (b[0] ** 2 * vc + dv - np.einsum('ij,ji->i', k, np.linalg.solve(Kd, k.T))
       + np.einsum('ij,jk,ik->i', u, Ainv, u))
print("rho", repr(b[0]), "beta", repr(b[1]))
print("se", repr(np.sqrt(Ainv[0, 0])), repr(np.sqrt(Ainv[1, 1])))
for p, m, v in zip(probes, mean, var):
    print(list(p), repr(m), repr(np.sqrt(v)))
