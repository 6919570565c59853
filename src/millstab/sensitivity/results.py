"""Result types of the sensitivity studies: small frozen dataclasses with a JSON-ready ``to_dict``
(the fields ``millstab sensitivity --out`` writes) and ``to_json()`` / ``from_json()`` that round-trip.

Every MSE is in mm² (depths in mm before squaring); speeds in rev/min; parameters in SI
(fn [Hz], k [N/m], ζ [-]).

``to_json()`` is ``to_dict()`` in plain JSON types plus ``"schema": "millstab.sensitivity.<kind>/1"``
(kind ``oat``, ``mc``, ``sobol``, ``morris``) and, for Monte Carlo, every path's MSE (``paths``), which
``to_dict`` leaves out; floats follow :mod:`millstab.jsondoc` (±∞ as ``"inf"``/``"-inf"``; ``null``
only for statistics that are not defined, e.g. a sample standard deviation of one path or an index of
an output that does not vary). ``from_json(doc, source)`` reads it back; derived entries (MC means,
convergence, ratios) are recomputed from the paths, not read.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from millstab.errors import InputError
from millstab.jsondoc import (check_schema, floats_in, int_in, names_in, need, number_in, per_name_in, per_name_out,
                              plain)


def schema(kind: str) -> str:
    """The ``"schema"`` of a sensitivity result's JSON: ``millstab.sensitivity.<kind>/1``."""
    return f"millstab.sensitivity.{kind}/1"


def _rpm_in(doc: dict, source: str) -> np.ndarray:
    return floats_in(need(need(doc, "speeds", source, dict), "rpm", f"{source}: speeds", list), f"{source}: speeds.rpm")


def _bounds_in(doc: dict, names: tuple[str, ...], source: str) -> np.ndarray:
    """(P, 2) bounds from {name: [lower, upper]}."""
    b = per_name_in(need(doc, "bounds", source, dict), names, f"{source}: bounds", ndim=1).T
    if b.shape != (len(names), 2):
        raise InputError(f"{source}: bounds", f"shape {b.shape}", "one [lower, upper] pair per parameter")
    return b


def _stats_in(value: Any, names: tuple[str, ...], source: str, ndim: int) -> dict[str, np.ndarray]:
    """{statistic: array} from {statistic: {name: value(s)}} (``null``: not defined)."""
    if not isinstance(value, dict):
        raise InputError(source, type(value).__name__, "must be an object {statistic: {parameter: value}}")
    return {key: per_name_in(v, names, f"{source}.{key}", ndim=ndim, nan_ok=True) for key, v in value.items()}


def _speeds(rpm: np.ndarray) -> dict[str, Any]:
    r = np.asarray(rpm, float)
    return {"count": int(r.size), "rpm_min": float(r.min()), "rpm_max": float(r.max()), "rpm": r}


def _row(label: str, values, width: int = 11) -> str:
    """One labelled row of a printed table (``-`` where not finite)."""
    return f"{label:<22}" + "".join(f"{v:>{width}.5f}" if np.isfinite(v) else f"{'-':>{width}}" for v in values)


@dataclass(frozen=True, eq=False)
class OATResult:
    """One-at-a-time sensitivity (the seed paper's Algorithm 1).

    Attributes:
        names: parameter names (P,), e.g. fn_x, k_x, zeta_x, fn_y, k_y, zeta_y.
        theta: the centre values (P,) [Hz, N/m, -].
        eps: relative perturbations (E,); parameter j is set to (1 + eps)·theta_j, the others kept.
        mse_mm2: MSE (P, E) [mm²] of each perturbed SLD against the original, over ``rpm``.
        rpm: spindle speeds (S,) [rev/min].
        depth_ref_mm: the original SLD (S,) [mm].
        engine: stability engine name.
    """

    names: tuple[str, ...]
    theta: np.ndarray
    eps: np.ndarray
    mse_mm2: np.ndarray
    rpm: np.ndarray
    depth_ref_mm: np.ndarray
    engine: str = "zoa"

    def to_dict(self) -> dict[str, Any]:
        return {"method": "oat", "engine": self.engine, "units": {"mse": "mm^2", "theta": "Hz, N/m, -"},
                "centre": dict(zip(self.names, map(float, self.theta))), "eps": self.eps,
                "speeds": _speeds(self.rpm), "depth_ref_mm": self.depth_ref_mm,
                "mse_mm2": {n: self.mse_mm2[j] for j, n in enumerate(self.names)}}

    def summary(self) -> str:
        """What ``millstab sensitivity oat`` prints under its header: the MSE [mm²] per change and parameter."""
        lines = [f"{'MSE [mm^2]':<12}" + "".join(f"{n:>11}" for n in self.names)]
        for k, e in enumerate(self.eps):
            lines.append(f"eps {e:+7.3f} " + "".join(f"{v:>11.5f}" for v in self.mse_mm2[:, k]))
        return "\n".join(lines)

    def table(self) -> tuple[list[str], list]:
        """(header, columns), one row per parameter: the MSE [mm²] per relative change (``mse_mm2_eps+0.05``)."""
        return (["parameter"] + [f"mse_mm2_eps{e:+g}" for e in self.eps],
                [list(self.names)] + [[float(v) for v in self.mse_mm2[:, k]] for k in range(self.eps.size)])

    def figure(self, ax=None, *, title: str | None = None):
        """Its figure (:func:`millstab.plot.sensitivity.plot_oat`), into ``ax``'s place or a new figure."""
        from millstab.plot.sensitivity import plot_oat

        return plot_oat(self, title=title, ax=ax)

    def to_json(self) -> dict[str, Any]:
        """:meth:`to_dict` in plain JSON types with ``"schema": "millstab.sensitivity.oat/1"``.

        Raises:
            ValueError: a NaN anywhere (a result never carries one silently)."""
        return {"schema": schema("oat"), **plain(self.to_dict(), "oat")}

    @classmethod
    def from_json(cls, doc: Any, source: str = "oat sensitivity") -> "OATResult":
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        check_schema(doc, schema("oat"), source)
        centre = need(doc, "centre", source, dict)
        names = tuple(centre)
        return cls(names=names, theta=per_name_in(centre, names, f"{source}: centre"),
                   eps=floats_in(need(doc, "eps", source, list), f"{source}: eps"),
                   mse_mm2=per_name_in(need(doc, "mse_mm2", source, dict), names, f"{source}: mse_mm2", ndim=1).T,
                   rpm=_rpm_in(doc, source),
                   depth_ref_mm=floats_in(need(doc, "depth_ref_mm", source, list), f"{source}: depth_ref_mm"),
                   engine=need(doc, "engine", source, str))


@dataclass(frozen=True, eq=False)
class MCResult:
    """Monte Carlo sensitivity (the seed paper's Algorithm 2 and Table 6).

    Each of ``n`` paths draws every parameter uniformly in [(1 − t)p, (1 + t)p], makes the SLD, then
    scales each parameter in turn by (1 + eps) and records the MSE [mm²] against that path's SLD.

    Attributes:
        names: parameter names (P,).
        theta: the centre p (P,) [Hz, N/m, -].
        t, eps, seed, n: the study's settings (seed: numpy Generator seed).
        rpm: speeds (S,) [rev/min].
        mse_mm2: every path's MSE (n, P) [mm²] (kept in memory, not written to JSON).
        mean: mean MSE per parameter (P,) [mm²].
        sd: population standard deviation (1/n, as the paper's Algorithm 2) (P,) [mm²].
        sd_sample: sample standard deviation (1/(n − 1)) (P,) [mm²].
        sem: standard error of each mean, sd_sample/√n (P,) [mm²].
    """

    names: tuple[str, ...]
    theta: np.ndarray
    t: float
    eps: float
    seed: int
    n: int
    rpm: np.ndarray
    mse_mm2: np.ndarray
    engine: str = "zoa"
    mean: np.ndarray = field(init=False)
    sd: np.ndarray = field(init=False)
    sd_sample: np.ndarray = field(init=False)
    sem: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        m = self.mse_mm2
        object.__setattr__(self, "mean", m.mean(axis=0))
        object.__setattr__(self, "sd", m.std(axis=0, ddof=0))
        s1 = m.std(axis=0, ddof=1) if m.shape[0] > 1 else np.full(m.shape[1], np.nan)
        object.__setattr__(self, "sd_sample", s1)
        object.__setattr__(self, "sem", s1 / np.sqrt(m.shape[0]))

    def running(self, points: int = 200) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Convergence: (paths (K,), running mean (K, P) [mm²], running SEM (K, P) [mm²]) at K
        log-spaced path counts up to n (the last one is n)."""
        n = self.mse_mm2.shape[0]
        k = np.unique(np.geomspace(1, n, min(points, n)).round().astype(np.int64))
        c1 = np.cumsum(self.mse_mm2, axis=0)
        c2 = np.cumsum(self.mse_mm2 ** 2, axis=0)
        s1, s2 = c1[k - 1], c2[k - 1]
        kk = k[:, None].astype(float)
        mean = s1 / kk
        var = np.where(kk > 1, (s2 - kk * mean ** 2) / np.maximum(kk - 1, 1), np.nan)
        return k, mean, np.sqrt(np.clip(var, 0, None) / kk)

    def ratio(self, a: str, b: str) -> float:
        """mean[a] / mean[b], e.g. ``ratio("fn_x", "k_x")``."""
        return float(self.mean[self.names.index(a)] / self.mean[self.names.index(b)])

    def to_dict(self, paper: dict[str, dict[str, float]] | None = None) -> dict[str, Any]:
        """JSON form. Per parameter name a dict with ``mean`` and ``sd`` (population) in mm² (the
        public contract), plus ``sd_sample``, ``sem``; settings, speeds, convergence and, when
        given, the paper's Table 6 values beside ours."""
        out: dict[str, Any] = {"method": "mc", "engine": self.engine, "units": {"mse": "mm^2", "theta": "Hz, N/m, -"},
                               "n": self.n, "seed": self.seed, "t": self.t, "eps": self.eps,
                               "parameters": list(self.names), "centre": dict(zip(self.names, map(float, self.theta))),
                               "speeds": _speeds(self.rpm)}
        for j, name in enumerate(self.names):
            out[name] = {"mean": float(self.mean[j]), "sd": float(self.sd[j]), "sd_sample": float(self.sd_sample[j]),
                         "sem": float(self.sem[j]), "n": self.n}
        k, rm, rs = self.running(100)
        out["convergence"] = {"paths": k, "running_mean": {n: rm[:, j] for j, n in enumerate(self.names)},
                              "running_sem": {n: rs[:, j] for j, n in enumerate(self.names)}}
        ratios = {}
        for d in ("x", "y"):
            if f"fn_{d}" in self.names and f"k_{d}" in self.names:
                ratios[f"fn_{d}/k_{d}"] = self.ratio(f"fn_{d}", f"k_{d}")
        if ratios:
            out["ratios"] = ratios
        if paper:
            out["paper"] = paper
            pr = {}
            for d in ("x", "y"):
                if f"fn_{d}" in paper and f"k_{d}" in paper:
                    pr[f"fn_{d}/k_{d}"] = paper[f"fn_{d}"]["mean"] / paper[f"k_{d}"]["mean"]
            out["paper_ratios"] = pr
        return out

    def summary(self, paper: dict | None = None, paper_comparable: bool = False) -> str:
        """What ``millstab sensitivity mc`` prints under its header: the settings, mean, SD and SEM of the MSE
        [mm²] per parameter, with ``paper`` (Table 6) its mean and SD (tagged where the run is not comparable),
        and the ratio of the fn and k sensitivities."""
        lines = [f"Monte Carlo sensitivity: N = {self.n}, t = {self.t:g}, eps = {self.eps:g}, seed {self.seed}",
                 f"{'MSE [mm^2]':<22}" + "".join(f"{n:>11}" for n in self.names),
                 _row("mean (millstab)", self.mean), _row("SD 1/N (millstab)", self.sd),
                 _row("SEM (millstab)", self.sem)]
        if paper and all(n in paper for n in self.names):
            tag = "" if paper_comparable else " [other structure]"
            lines += [_row("mean (paper Table 6)", [paper[n]["mean"] for n in self.names]) + tag,
                      _row("SD (paper Table 6)", [paper[n]["sd"] for n in self.names]) + tag]
        ratios = []
        for d in ("x", "y"):
            if f"fn_{d}" in self.names and f"k_{d}" in self.names:
                s = f"fn_{d}/k_{d} = {self.ratio(f'fn_{d}', f'k_{d}'):.1f}"
                if paper and f"fn_{d}" in paper:
                    s += f" (paper {paper[f'fn_{d}']['mean'] / paper[f'k_{d}']['mean']:.1f})"
                ratios.append(s)
        if ratios:
            lines.append("ratio of mean sensitivities: " + "; ".join(ratios))
        if paper:
            lines.append("paper Table 6: N = 10 000, t = 0.1, eps = 1 % around Ex.1 predicted values; its speed set "
                         "is not given" + ("" if paper_comparable else "; this run differs in centre or settings"))
        return "\n".join(lines)

    def table(self, paper: dict | None = None) -> tuple[list[str], list]:
        """(header, columns), one row per parameter: mean, SD (1/N) and SEM of the MSE [mm²], and with ``paper``
        (Table 6, when it names every parameter) the paper's mean and SD."""
        header, cols = ["parameter", "mean_mm2", "sd_mm2", "sem_mm2"], [list(self.names)]
        cols += [[float(v) for v in getattr(self, k)] for k in ("mean", "sd", "sem")]
        if paper and all(n in paper for n in self.names):
            header += ["paper_mean_mm2", "paper_sd_mm2"]
            cols += [[paper[n][k] for n in self.names] for k in ("mean", "sd")]
        return header, cols

    def figure(self, ax=None, *, paper: dict | None = None, title: str | None = None):
        """Its figure (:func:`millstab.plot.sensitivity.plot_mc_convergence`), into ``ax``'s place or a new figure."""
        from millstab.plot.sensitivity import plot_mc_convergence

        return plot_mc_convergence(self, paper=paper, title=title, ax=ax)

    def to_json(self, paper: dict[str, dict[str, float]] | None = None, paths: bool = True) -> dict[str, Any]:
        """:meth:`to_dict` in plain JSON types with ``"schema": "millstab.sensitivity.mc/1"`` and, with
        ``paths``, every path's MSE, ``paths: {"mse_mm2": {name: [n values]}}`` [mm²] (so that :meth:`from_json`
        rebuilds the result exactly; ~20 characters per value: 1.2 MB for the paper's 10 000 paths × 6).
        Without ``paths`` (the command line's file: a 10^6-path study would be 120 MB) the statistics only.

        Raises:
            ValueError: a NaN in the inputs or the paths (statistics may be ``null``: not defined)."""
        d = self.to_dict(paper)
        stats = set(self.names) | {"convergence", "ratios", "paper", "paper_ratios"}
        out = {"schema": schema("mc")}
        out.update({k: plain(v, f"mc.{k}", nan_ok=k in stats) for k, v in d.items()})
        if paths:
            out["paths"] = {"mse_mm2": per_name_out(self.names, self.mse_mm2, "mc.paths.mse_mm2")}
        return out

    @classmethod
    def from_json(cls, doc: Any, source: str = "mc sensitivity") -> "MCResult":
        """Rebuild from :meth:`to_json` output (means and deviations recomputed from the paths).
        Raises InputError (wrong schema, missing or bad field)."""
        check_schema(doc, schema("mc"), source)
        names = names_in(need(doc, "parameters", source), f"{source}: parameters")
        if isinstance(doc, dict) and "paths" not in doc:
            raise InputError(f"{source}: paths", "missing", "the file holds the statistics only (as `millstab "
                             "sensitivity mc --out` writes them); a result rebuilds from to_json(paths=True)")
        paths = need(need(doc, "paths", source, dict), "mse_mm2", f"{source}: paths", dict)
        mse = per_name_in(paths, names, f"{source}: paths.mse_mm2", ndim=1)
        n = int_in(need(doc, "n", source), f"{source}: n")
        if mse.shape[0] != n:
            raise InputError(f"{source}: paths.mse_mm2", f"{mse.shape[0]} paths", f"n = {n} paths per parameter")
        return cls(names=names, theta=per_name_in(need(doc, "centre", source, dict), names, f"{source}: centre"),
                   t=number_in(need(doc, "t", source), f"{source}: t"),
                   eps=number_in(need(doc, "eps", source), f"{source}: eps"),
                   seed=int_in(need(doc, "seed", source), f"{source}: seed"), n=n, rpm=_rpm_in(doc, source),
                   mse_mm2=mse, engine=need(doc, "engine", source, str))


@dataclass(frozen=True, eq=False)
class SobolResult:
    """First- and total-order Sobol indices with confidence half-widths (SALib, Saltelli sampling).

    Attributes:
        names: parameter names (P,).
        bounds: input ranges (P, 2) [Hz, N/m, -] (uniform inputs).
        n: SALib base sample size (a power of 2); the engine ran n·(P + 2) structures.
        seed: sampler and bootstrap seed.
        rpm: speeds (S,) [rev/min]; depth_nominal_mm: the nominal SLD (S,) [mm].
        mse: indices of the SLD's MSE [mm²] against the nominal SLD: {S1, S1_conf, ST, ST_conf} each (P,).
        minimum: indices of the envelope minimum min_Ω b_lim [mm]: same keys, each (P,).
        blim: indices of b_lim at each speed: same keys, each (S, P).
        conf_level: confidence level of the ``*_conf`` half-widths (bootstrap).
    """

    names: tuple[str, ...]
    bounds: np.ndarray
    n: int
    seed: int
    rpm: np.ndarray
    depth_nominal_mm: np.ndarray
    mse: dict[str, np.ndarray]
    minimum: dict[str, np.ndarray]
    blim: dict[str, np.ndarray]
    conf_level: float = 0.95
    engine: str = "zoa"

    def to_dict(self) -> dict[str, Any]:
        def per_name(d):
            return {key: {n: v[..., j] for j, n in enumerate(self.names)} for key, v in d.items()}

        units = {"bounds": "Hz, N/m, -", "mse": "mm^2", "minimum": "mm", "blim": "mm", "indices": "-",
                 "depth_nominal_mm": "mm"}
        return {"method": "sobol", "engine": self.engine, "units": units, "n": self.n,
                "evaluations": self.n * (len(self.names) + 2),
                "seed": self.seed, "conf_level": self.conf_level, "parameters": list(self.names),
                "bounds": {n: self.bounds[j] for j, n in enumerate(self.names)}, "speeds": _speeds(self.rpm),
                "depth_nominal_mm": self.depth_nominal_mm, "mse": per_name(self.mse), "minimum": per_name(self.minimum),
                "blim": per_name(self.blim)}

    def summary(self) -> str:
        """What ``millstab sensitivity sobol`` prints under its header: S1 and ST (± confidence) of the MSE and of
        the minimum limit per parameter, and how many speeds each parameter has the largest total index of b_lim."""
        w = 15
        lines = [f"{'':<24}" + "".join(f"{nm:>{w}}" for nm in self.names)]
        for oname, d in (("MSE", self.mse), ("min b_lim", self.minimum)):
            for key in ("S1", "ST"):
                lines.append(f"{oname + ' ' + key:<24}" + "".join(f"{v:.3f}±{c:.3f}".rjust(w)
                                                                   for v, c in zip(d[key], d[key + '_conf'])))
        top = np.argmax(self.blim["ST"], axis=1)
        share = {nm: int(np.sum(top == j)) for j, nm in enumerate(self.names)}
        lines.append("largest total index of b_lim, speeds per parameter: " +
                     ", ".join(f"{k} {v}" for k, v in share.items() if v))
        return "\n".join(lines)

    def table(self) -> tuple[list[str], list]:
        """(header, columns), one row per parameter: S1, ST and their confidence half-widths of the MSE and of
        the minimum limit (``mse_S1`` … ``minimum_ST_conf``)."""
        keys = ("S1", "S1_conf", "ST", "ST_conf")
        pairs = [(f"{o}_{k}", d[k]) for o, d in (("mse", self.mse), ("minimum", self.minimum)) for k in keys]
        return ["parameter"] + [h for h, _ in pairs], [list(self.names)] + [[float(v) for v in c] for _, c in pairs]

    def figure(self, ax=None, *, title: str | None = None):
        """Its figure (:func:`millstab.plot.sensitivity.plot_sobol_speed`), into ``ax``'s place or a new figure."""
        from millstab.plot.sensitivity import plot_sobol_speed

        return plot_sobol_speed(self, title=title, ax=ax)

    def to_json(self) -> dict[str, Any]:
        """:meth:`to_dict` in plain JSON types with ``"schema": "millstab.sensitivity.sobol/1"`` (an index
        may be ``null``: not defined, e.g. for an output that does not vary).

        Raises:
            ValueError: a NaN in the inputs (bounds, speeds, nominal SLD)."""
        d = self.to_dict()
        stats = {"mse", "minimum", "blim"}
        return {"schema": schema("sobol"), **{k: plain(v, f"sobol.{k}", nan_ok=k in stats) for k, v in d.items()}}

    @classmethod
    def from_json(cls, doc: Any, source: str = "sobol sensitivity") -> "SobolResult":
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        check_schema(doc, schema("sobol"), source)
        names = names_in(need(doc, "parameters", source), f"{source}: parameters")
        return cls(names=names, bounds=_bounds_in(doc, names, source), n=int_in(need(doc, "n", source), f"{source}: n"),
                   seed=int_in(need(doc, "seed", source), f"{source}: seed"), rpm=_rpm_in(doc, source),
                   depth_nominal_mm=floats_in(need(doc, "depth_nominal_mm", source, list),
                                              f"{source}: depth_nominal_mm"),
                   mse=_stats_in(need(doc, "mse", source), names, f"{source}: mse", 0),
                   minimum=_stats_in(need(doc, "minimum", source), names, f"{source}: minimum", 0),
                   blim=_stats_in(need(doc, "blim", source), names, f"{source}: blim", 1),
                   conf_level=number_in(need(doc, "conf_level", source), f"{source}: conf_level"),
                   engine=need(doc, "engine", source, str))


@dataclass(frozen=True, eq=False)
class MorrisResult:
    """Morris elementary-effects screening (SALib) of the SLD's MSE [mm²] and the envelope minimum [mm].

    Attributes:
        outputs: {"mse": {...}, "minimum": {...}}, each {mu, mu_star, sigma, mu_star_conf} (P,) in the
            output's units.
    """

    names: tuple[str, ...]
    bounds: np.ndarray
    trajectories: int
    levels: int
    seed: int
    rpm: np.ndarray
    outputs: dict[str, dict[str, np.ndarray]]
    engine: str = "zoa"

    def to_dict(self) -> dict[str, Any]:
        return {"method": "morris", "engine": self.engine, "trajectories": self.trajectories, "levels": self.levels,
                "evaluations": self.trajectories * (len(self.names) + 1), "seed": self.seed,
                "parameters": list(self.names), "bounds": {n: self.bounds[j] for j, n in enumerate(self.names)},
                "speeds": _speeds(self.rpm), "units": {"mse": "mm^2", "minimum": "mm", "bounds": "Hz, N/m, -"},
                "outputs": {o: {key: {n: v[j] for j, n in enumerate(self.names)} for key, v in d.items()}
                            for o, d in self.outputs.items()}}

    def summary(self) -> str:
        """What ``millstab sensitivity morris`` prints under its header: μ* and σ of each output per parameter."""
        lines = [f"{'':<24}" + "".join(f"{nm:>11}" for nm in self.names)]
        for oname, d in self.outputs.items():
            lines.append(f"{oname + ' mu*':<24}" + "".join(f"{v:>11.4g}" for v in d["mu_star"]))
            lines.append(f"{oname + ' sigma':<24}" + "".join(f"{v:>11.4g}" for v in d["sigma"]))
        return "\n".join(lines)

    def table(self) -> tuple[list[str], list]:
        """(header, columns), one row per parameter: μ*, σ and μ*'s confidence of each output (``mse_mu_star``…)."""
        pairs = [(f"{o}_{k}", d[k]) for o, d in self.outputs.items() for k in ("mu_star", "sigma", "mu_star_conf")]
        return ["parameter"] + [h for h, _ in pairs], [list(self.names)] + [[float(v) for v in c] for _, c in pairs]

    def figure(self, ax=None, *, title: str | None = None):
        """Its figure (:func:`millstab.plot.sensitivity.plot_morris`), into ``ax``'s place or a new figure."""
        from millstab.plot.sensitivity import plot_morris

        return plot_morris(self, title=title, ax=ax)

    def to_json(self) -> dict[str, Any]:
        """:meth:`to_dict` in plain JSON types with ``"schema": "millstab.sensitivity.morris/1"`` (a
        statistic may be ``null``: not defined).

        Raises:
            ValueError: a NaN in the inputs (bounds, speeds)."""
        d = self.to_dict()
        return {"schema": schema("morris"), **{k: plain(v, f"morris.{k}", nan_ok=k == "outputs") for k, v in d.items()}}

    @classmethod
    def from_json(cls, doc: Any, source: str = "morris sensitivity") -> "MorrisResult":
        """Rebuild from :meth:`to_json` output. Raises InputError (wrong schema, missing or bad field)."""
        check_schema(doc, schema("morris"), source)
        names = names_in(need(doc, "parameters", source), f"{source}: parameters")
        outputs = need(doc, "outputs", source, dict)
        return cls(names=names, bounds=_bounds_in(doc, names, source),
                   trajectories=int_in(need(doc, "trajectories", source), f"{source}: trajectories"),
                   levels=int_in(need(doc, "levels", source), f"{source}: levels"),
                   seed=int_in(need(doc, "seed", source), f"{source}: seed"), rpm=_rpm_in(doc, source),
                   outputs={o: _stats_in(v, names, f"{source}: outputs.{o}", 0) for o, v in outputs.items()},
                   engine=need(doc, "engine", source, str))
