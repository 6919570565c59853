"""A cheap surrogate of an accurate engine's likelihood: the zero-order limits times a fitted correction.

    b̃(θ, Ω) = b_zoa(θ, Ω) · exp(δ̂_Ω(ln θ)),   δ = ln b_acc − ln b_zoa,

one δ̂ per column of the data (speed, condition), fitted on a design of accurate evaluations (prior draws,
:meth:`Corrected.fit`). Each column's fit sees only its own column's values, so a speed's surrogate limit
does not depend on the other speeds of the call. The surrogate serves as L̃ in
:func:`millstab.update.sampler.corrected_smc`, which evaluates the accurate likelihood at the final
particles and reweights, so the posterior is the accurate engine's whatever the surrogate's error; the error
only costs ESS (and, when large, a bridge with accurate moves).

The regression: ridge-regularised least squares in the standardised ln θ, linear (1 + P features,
``kind="linear"``, the default) or with the quadratic monomials (1 + P + P(P+1)/2, 28 for 6 parameters,
``"quadratic"``); or a Gaussian process per column (scikit-learn, anisotropic RBF plus white noise, ``"gp"``).
Measured on the low-immersion case of docs/updating.md (RMS error in ln b, trained on 193 zero-order posterior
particles, tested on 168 spectral posterior ones): constant 0.124, linear 0.112, GP 0.123,
quadratic 0.181 (over-fitted), the correction's own sd ~0.12–0.17: at a/D 0.1 the correction is rough on the
posterior's scale (the lobes of the two models differ in shape, not by a smooth factor), so no regression
tried predicts much of it; linear is the cheapest and was best. The held-out error is reported
(:attr:`Corrected.heldout_rms`) so the accuracy is seen, not assumed (docs/updating-measured.md, "A
surrogate-corrected update").

Units: δ in ln(mm/mm) (dimensionless); the likelihood's interface as :mod:`millstab.update.likelihood`.
"""

from __future__ import annotations

import numpy as np

from millstab.errors import InputError
from millstab.update.likelihood import Likelihood

#: ridge weight (on standardised features) of the quadratic fit: keeps the normal equations well posed
#: when a column has few finite training rows, negligible otherwise
RIDGE = 1e-6
#: the share of the design held out to measure the surrogate's error before the final fit on all of it
HOLDOUT = 0.25
KINDS = ("linear", "quadratic", "gp")
#: widen the surrogate's depth noise by the correction's held-out error (a defensive importance proposal);
#: measured once (quadratic fit, 300 samples): the ESS fraction 0.10 -> 0.07, so not shown to help here
INFLATE = True


def _features(x: np.ndarray, kind: str) -> np.ndarray:
    """[1, x_i] (linear) or [1, x_i, x_i x_j (i ≤ j)] (quadratic) of standardised rows x (B, P)."""
    if kind == "linear":
        return np.hstack([np.ones((x.shape[0], 1)), x])
    i, j = np.triu_indices(x.shape[1])
    return np.hstack([np.ones((x.shape[0], 1)), x, x[:, i] * x[:, j]])


class _Fit:
    """δ̂ of every column from rows x (standardised ln θ): quadratic ridge or one GP per column."""

    def __init__(self, x: np.ndarray, delta: np.ndarray, kind: str, seed: int):
        self.kind, self.models = kind, []
        if kind != "gp":
            f = _features(x, kind)
            self.coef = np.zeros((f.shape[1], delta.shape[1]))
            for s in range(delta.shape[1]):  # once per column at fit time (each column's own finite rows)
                ok = np.isfinite(delta[:, s])
                if ok.sum() < 2:
                    continue
                a = f[ok]
                self.coef[:, s] = np.linalg.solve(a.T @ a + RIDGE * ok.sum() * np.eye(a.shape[1]), a.T @ delta[ok, s])
        else:
            from sklearn.gaussian_process import GaussianProcessRegressor
            from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

            for s in range(delta.shape[1]):
                ok = np.isfinite(delta[:, s])
                kern = ConstantKernel(0.01) * RBF(np.ones(x.shape[1])) + WhiteKernel(1e-4)
                gp = GaussianProcessRegressor(kern, normalize_y=True, random_state=seed)
                self.models.append(gp.fit(x[ok], delta[ok, s]) if ok.sum() >= 2 else None)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        if self.kind != "gp":
            return _features(x, self.kind) @ self.coef
        return np.column_stack([np.zeros(x.shape[0]) if m is None else m.predict(x) for m in self.models])


class Corrected:
    """The surrogate log-likelihood u -> log L̃(u) of the accurate likelihood ``exact``, built on ``cheap``
    (the same prior and evidence with the zero-order engine); batched like :class:`Likelihood`.

    Attributes:
        design: accurate rows used to fit (prior draws), n_train of them in the final fit.
        heldout_rms: per column, the RMS error of δ̂ [ln b] on the held-out share of the design (fitted on
            the rest), before the final fit on all of it.
        delta_sd: per column, the sd of δ itself over the design (what a constant correction would miss).
    """

    def __init__(self, exact: Likelihood, cheap: Likelihood):
        if exact.batch is not None or len(exact._groups) > 1:
            raise InputError("sampler", "surrogate", "a test-day effect or several stickouts: use the delayed sampler")
        self.exact, self.cheap = exact, cheap
        self.p = exact.prior.size
        self._fit = None

    def design_from(self, u: np.ndarray, m: int, rng: np.random.Generator) -> np.ndarray:
        """m distinct rows of the particles u (at most as many as are distinct): the design of :meth:`fit`."""
        rows = np.unique(u, axis=0)
        return rows[np.sort(rng.choice(rows.shape[0], min(m, rows.shape[0]), replace=False))]

    def fit(self, v: np.ndarray, kind: str = "linear", seed: int = 0) -> Corrected:
        """Fit δ̂ on the design rows v (sampler vectors, (m, ≥ P)): ONE accurate and ONE zero-order call for all."""
        if kind not in KINDS:
            raise InputError("surrogate", kind, "one of " + ", ".join(KINDS))
        v = np.atleast_2d(np.asarray(v, dtype=float))
        if v.shape[0] < 10:
            raise InputError("design", v.shape[0], "at least 10 accurate evaluations to fit the correction")
        acc, _, _, ok = self.exact._limits(v)
        zoa, _, _, _ = self.cheap._limits(v)
        with np.errstate(divide="ignore", invalid="ignore"):
            delta = np.log(acc / zoa)
        delta[~ok] = np.nan
        delta[~np.isfinite(delta)] = np.nan  # no boundary in one engine: not a correction to learn
        u = v[ok, :self.p]
        delta = delta[ok]
        self._mu, self._sd = u.mean(0), u.std(0) + 1e-12
        x = (u - self._mu) / self._sd
        m = int(round(HOLDOUT * x.shape[0]))
        held = _Fit(x[m:], delta[m:], kind, seed)
        err = held(x[:m]) - delta[:m]
        with np.errstate(invalid="ignore"):
            self.heldout_rms = np.sqrt(np.nanmean(err**2, axis=0))
            self.delta_sd = np.nanstd(delta, axis=0)
        self._fit = _Fit(x, delta, kind, seed)
        self.kind, self.n_train, self.design = kind, x.shape[0], v
        # a defensive surrogate: its depth noise widened by the correction's held-out error (in quadrature, per
        # column), so the surrogate posterior covers the accurate one and the importance weights stay bounded
        # where the correction is poor instead of the surrogate posterior being confidently elsewhere
        import copy

        self._wide = copy.copy(self.cheap)
        rms = np.nan_to_num(self.heldout_rms) if INFLATE else np.zeros_like(self.heldout_rms)
        ev = self.cheap.evidence
        self._wide._sig_c = np.hypot(self.cheap._sig_c, rms[self.cheap._ic] * ev.cut_depth_mm)
        self._wide._sig_p = np.hypot(self.cheap._sig_p, rms[self.cheap._ip] * ev.pt_depth_mm)
        return self

    def correction(self, u: np.ndarray) -> np.ndarray:
        """δ̂ (B, S) [ln b] at rows u = ln θ (B, ≥ P)."""
        return self._fit((np.atleast_2d(u)[:, :self.p] - self._mu) / self._sd)

    def __call__(self, v: np.ndarray) -> np.ndarray:
        """log L̃ (B,) of sampler vectors v (B, P [+ Q]): ONE zero-order call; −inf outside the support."""
        depth, hz, w, ok = self.cheap._limits(v)
        depth = depth * np.exp(self.correction(np.atleast_2d(v)))
        return np.where(ok, self._wide.from_limits(depth, hz, noise=w), -np.inf)

    def report(self) -> dict:
        """A JSON-ready summary of the fit."""
        return {"kind": self.kind, "design": int(self.n_train),
                "heldout_rms_ln_b": [None if not np.isfinite(e) else float(e) for e in self.heldout_rms],
                "delta_sd_ln_b": [None if not np.isfinite(e) else float(e) for e in self.delta_sd]}


__all__ = ["Corrected", "KINDS"]
