"""The posterior of an update: samples, summaries, x↔y exchange modes, and its JSON form.

Exchange twins. With the zero-order engine, exchanging the x and y modes (fn, ζ swapped, stiffnesses
rescaled by α_xx/α_yy, :func:`millstab.identify.symmetry.exchange_map`) leaves every boundary exactly
unchanged, so the cuts alone cannot tell a structure from its twin; only the prior can. Each sample is
assigned to the orientation whose prior density is higher (the sample itself, "as tested", or its
exchange, "x↔y exchanged"); when both hold a noticeable share (≥ :data:`MODE_SHARE`) the posterior
is bimodal: the summaries are then given per mode and the top-level summary is that of the larger
mode, with a warning, rather than an average across the two that describes neither. When the prior
itself is x/y symmetric (identical tap tests in x and y) it cannot choose either: the two modes are
then told apart by the order of the first differing x/y pair (fn_x < fn_y) and labelled so. Near-twins (other
engines, or fixed parameters) show up the same way when the assignment splits the samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from millstab.errors import InputError
from millstab.identify.symmetry import exchange_map, exchanged
from millstab.update.batch import BatchPosterior, new_day, summary_of
from millstab.update.prior import Prior

SCHEMA = "millstab.posterior/3"
#: older layouts that still load (/2: one cutting condition, the prior's; /1: also no learned noise levels,
#: a Gaussian prior)
OLD_SCHEMAS = ("millstab.posterior/2", "millstab.posterior/1")
#: the code of each kind of warning (``warning_codes`` in the JSON), by the start of its message
WARNING_CODES = (("the cuts contradict the hammer test", "prior-data-conflict"), ("bimodal posterior", "bimodal"),
                 ("every cut", "one-sided-data"),
                 ("the zoa engine averages the cutting force", "time-averaged-model"))
#: the least share of samples for a second exchange mode to be reported as a mode
MODE_SHARE = 0.02


def warning_code(message: str) -> str:
    """The code of a warning message (:data:`WARNING_CODES`; ``"data"`` for any other)."""
    return next((c for start, c in WARNING_CODES if str(message).startswith(start)), "data")


def bimodal_warning(modes: list[dict]) -> str | None:
    """The one-line warning of a posterior split between exchange twins, or ``None``."""
    if len(modes) < 2:
        return None
    return (f"bimodal posterior: the x<->y exchange twin holds {modes[1]['share']:.0%} of the samples "
            f"(the cuts cannot tell x from y; only the prior can). 'parameters' summarises the larger "
            f"mode ({modes[0]['label']}); see 'modes'")


def summary(theta: np.ndarray, names) -> dict[str, dict[str, float]]:
    """{name: {mean, sd, q05, q50, q95}} of samples θ (N, P)."""
    q = np.quantile(theta, [0.05, 0.5, 0.95], axis=0)
    return {n: {"mean": float(theta[:, j].mean()), "sd": float(theta[:, j].std(ddof=1) if theta.shape[0] > 1 else 0.0),
                "q05": float(q[0, j]), "q50": float(q[1, j]), "q95": float(q[2, j])} for j, n in enumerate(names)}


def exchange_of(prior: Prior, engine: str):
    """(perm, shift) of the x↔y exchange on the full u = ln θ vector (Kt mapped to itself), or ``None``
    (also with Kr free: the exchange's stiffness ratio α_xx/α_yy depends on Kr, so no fixed shift maps
    every sample; and with process damping free, whose contact matrix is not the exchange's)."""
    xm = exchange_map(prior.par, prior.cutting, engine)
    if xm is None or prior.kr_free or prior.pd_free:
        return None
    perm, shift = xm
    if prior.kt_free:
        perm, shift = np.append(perm, prior.size - 1), np.append(shift, 0.0)
    return perm, shift


def split_modes(prior: Prior, theta: np.ndarray, engine: str) -> np.ndarray | None:
    """Boolean (N,): True where the exchanged sample has the higher prior density; ``None`` without an exchange."""
    xm = exchange_of(prior, engine)
    if xm is None:
        return None
    u = np.log(theta)
    u2 = np.log(exchanged(theta, xm))
    diff = prior.logpdf(u2) - prior.logpdf(u)
    # a prior symmetric in x and y (identical tap tests) cannot choose: then fn_x ≤ fn_y (the first
    # differing pair, as identify's canonical form) defines "as tested"
    tie = np.abs(diff) <= 1e-9 * (1 + np.abs(prior.logpdf(u)))
    d = u - u2
    big = np.abs(d) > 1e-12
    first = np.where(big.any(axis=1), big.argmax(axis=1), 0)
    return np.where(tie, d[np.arange(d.shape[0]), first] > 0, diff > 0)


def _symmetric(prior: Prior, engine: str) -> bool:
    """True when the prior cannot tell a structure from its exchange (identical x and y tap tests)."""
    xm = exchange_of(prior, engine)
    if xm is None:
        return False
    u = prior.mean_u[None]
    return bool(abs(prior.logpdf(np.log(exchanged(np.exp(u), xm)))[0] - prior.logpdf(u)[0])
                <= 1e-9 * (1 + abs(prior.logpdf(u)[0])))


@dataclass(frozen=True, eq=False)
class Posterior:
    """Posterior samples of the free parameters and everything ``map``/``recommend`` need.

    Attributes:
        prior: the prior (structure, cutting conditions, spreads, noise levels).
        samples: (N, P) equally weighted samples [Hz, N/m, -, N/m²] in the order of ``prior.names``.
        engine: the engine the likelihood used.
        diagnostics: the sampler's diagnostics (:meth:`SMCResult.diagnostics`).
        cuts: the data: {"rpm", "depth_mm", "label", "chatter_hz"} lists (for plots).
        warnings: messages for the user (the prior–data conflict and a bimodal split included).
        noise: (N, Q) samples of the learned noise levels ``prior.noise_names`` (ε; the factor s on
            the depth noise), or ``None``: held at the prior's values.
        batch: the test days' shifts of ln fn (:mod:`millstab.update.batch`), or ``None`` (no test-day effect).
        provenance: what it was made from, ``{"config": the config's name}`` (set by
            :func:`millstab.api.update`), written as the JSON's top-level ``"config"``: every door writes the
            same file (the command line added the key after ``to_json``).
        conditions: the cutting conditions the cuts were made in (``cuts["condition"]`` indexes them);
            ``()``: every cut in ``prior.cutting``. Decisions (maps, recommendations, predictions) are
            computed for ``prior.cutting``, the config's condition unless :meth:`for_condition` chose another.
        engine_options: the engine's discretisation the samples were fitted with (``update(engine_options=)``,
            e.g. ``{"steps": 40}`` for sdm; ``{}``: the engine's own choice): every decision from this
            posterior (map, recommend, next test, predict) evaluates the limits with it, so the decisions
            use the model the data were explained by; :meth:`with_engine_options` overrides it.
    """

    prior: Prior
    samples: np.ndarray
    engine: str = "zoa"
    diagnostics: dict = field(default_factory=dict)
    cuts: dict = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    noise: np.ndarray | None = None
    batch: BatchPosterior | None = None
    provenance: dict = field(default_factory=dict)
    conditions: tuple = ()
    #: the tool diameter [mm] of the config (a ``radial_width_mm`` condition needs it), or ``None``
    diameter_mm: float | None = None
    engine_options: dict = field(default_factory=dict)

    def __post_init__(self):
        # the bimodal split is a property of the samples: every posterior carries its warning in .warnings
        if self.samples.ndim == 2 and self.samples.shape[0] > 1 and not any(
                str(w).startswith("bimodal posterior") for w in self.warnings):
            bim = bimodal_warning(self.modes())
            if bim is not None:
                object.__setattr__(self, "warnings", tuple(self.warnings) + (bim,))

    @property
    def names(self) -> tuple[str, ...]:
        return self.prior.names

    def with_engine_options(self, options: dict | None, field: str = "engine_options") -> Posterior:
        """The same samples deciding with the engine's discretisation ``options`` over the fitted ones (a key
        given replaces the fitted value, the others stay); ``None`` or ``{}``: this posterior itself.

        Raises:
            InputError: a keyword the engine does not take or a bad value (:func:`millstab.forward.engine_options`,
                named ``field``).
        """
        from dataclasses import replace

        from millstab.forward import engine_options

        if not options:
            return self
        return replace(self, engine_options=dict(engine_options(self.engine, {**self.engine_options, **options},
                                                                field)))

    @property
    def condition(self):
        """The cutting condition decisions from this posterior are computed for (``prior.cutting``)."""
        return self.prior.cutting

    @property
    def trained_conditions(self) -> tuple:
        """The distinct cutting conditions of the cuts (``(prior.cutting,)`` for a one-condition posterior)."""
        return tuple(self.conditions) or (self.prior.cutting,)

    def for_condition(self, cutting) -> Posterior:
        """The same samples, deciding for another cutting condition (a :class:`~millstab.model.Cutting`
        of the same tool family: its Kt and Kr are replaced by the trained ones, which the samples hold):
        the structure and coefficients are shared by every condition, only the directional factors change.
        ``None``: this posterior itself."""
        from dataclasses import replace

        if cutting is None:
            return self
        # the trained tool's coefficients (and process damping, diameter), the target's teeth and angles
        c = replace(self.prior.cutting, teeth=cutting.teeth, entry=cutting.entry, exit=cutting.exit)
        return replace(self, prior=replace(self.prior, cutting=c), conditions=self.trained_conditions)

    def cuts_in_condition(self) -> dict:
        """The ``cuts`` record restricted to the rows cut in :attr:`condition` (all rows of a one-condition
        posterior): the cuts that speak directly about this condition's limits (the data guard's)."""
        from millstab.points import same_condition

        c = self.cuts or {}
        idx = c.get("condition")
        if not idx or not self.conditions:
            if self.conditions and not any(same_condition(k, self.prior.cutting) for k in self.conditions):
                return {}
            return c
        keep = [same_condition(self.conditions[int(i)], self.prior.cutting) for i in idx]
        return {k: ([x for x, m in zip(v, keep) if m] if isinstance(v, list) and len(v) == len(keep) else v)
                for k, v in c.items()}

    @property
    def u(self) -> np.ndarray:
        """Samples in log coordinates (N, P)."""
        return np.log(self.samples)

    @cached_property
    def decision_u(self) -> np.ndarray:
        """The samples for decisions about a new day (N, P): :attr:`u`, or with a test-day effect each
        sample's fn shifted by a fresh draw of the day's shift (:func:`millstab.update.batch.new_day`)."""
        return new_day(self.u, self.prior)

    @property
    def label_error(self) -> np.ndarray:
        """The label error ε of each sample (N,) (learned, or the prior's held value)."""
        return self._noise()[0]

    @property
    def sigma_depth_factor(self) -> np.ndarray:
        """The factor s on the prior's depth noise of each sample (N,) (learned, or 1)."""
        return self._noise()[1]

    def _noise(self) -> tuple[np.ndarray, np.ndarray]:
        n = self.samples.shape[0]
        eps, fac = np.full(n, float(self.prior.label_error)), np.ones(n)
        if self.noise is not None:
            for j, name in enumerate(self.prior.noise_names):
                if name == "label_error":
                    eps = self.noise[:, j]
                else:
                    fac = self.noise[:, j]
        return eps, fac

    def sampler_state(self, rng: np.random.Generator | None = None) -> np.ndarray:
        """The sampler's vectors of these samples (N, prior.dim): ln θ and the noise coordinates; noise
        levels a posterior lacks (an older file, or a prior draw) are drawn from their prior with ``rng``."""
        u = self.u
        if self.prior.dim == self.prior.size:
            return u
        if self.noise is not None and self.noise.shape[1] == self.prior.dim - self.prior.size:
            return np.hstack([u, self.prior.noise_coordinates(*self._noise())])
        return np.hstack([u, self.prior.sample_noise(u.shape[0], rng or np.random.default_rng(0))])

    def summary(self) -> str:
        """One line: how the sampler got here (tempering stages, acceptance range, likelihood calls, time)."""
        d = self.diagnostics
        moved = d.get("moves") or [1] * len(d.get("acceptance") or [])
        # a stage without moves (the zero-order screen's start of an accurate update) has no acceptance to show
        acc = [a for a, m in zip(d.get("acceptance") or [], moved) if m] or [float("nan")]
        span = f"{min(acc):.2f}" if min(acc) == max(acc) else f"{min(acc):.2f}-{max(acc):.2f}"
        stages = d.get("stages", "?")
        return (f"{stages} tempering stage{'' if stages == 1 else 's'}, acceptance {span}, "
                f"{d.get('loglik_calls', '?')} likelihood calls, {d.get('time_s', float('nan')):.1f} s")

    def figure(self, ax=None):
        """The pair plot of the samples in the trade's units (:func:`millstab.plot.update.plot_corner`), into
        ``ax``'s place or a new figure. (The P(stable) map is computed from the posterior first:
        ``millstab.api.p_stable`` then ``map_figure``.)"""
        from millstab.plot.update import plot_corner

        return plot_corner(self.samples, self.names, self.prior.units(), ax=ax)

    def table(self) -> tuple[tuple[str, ...], tuple[list, ...]]:
        """(header, columns) of the posterior as the trade reads it (:data:`millstab.units.SHOWN`): per
        parameter of the main mode its prior median, mean, sd, 5 % and 95 % quantiles and unit, then the
        learned noise levels (``label_error``; ``sigma_depth ×``, the factor on the prior's depth noise), then
        each test day's fn factor (``fn × DAY``) with a test-day effect."""
        from millstab.units import SHOWN

        keys = ("mean", "sd", "q05", "q95")
        main = self.modes()[0]["parameters"]
        rows = []
        for j, (name, unit) in enumerate(zip(self.names, self.prior.units())):
            sc, shown = SHOWN.get(unit, (1.0, unit))
            rows.append((name, self.prior.median[j] * sc, *(main[name][k] * sc for k in keys), shown))
        if self.noise is not None:
            for name, s in summary(self.noise, list(self.prior.noise_names)).items():
                label, med = (("label_error", self.prior.label_error) if name == "label_error"
                              else ("sigma_depth ×", 1.0))
                rows.append((label, float(med), *(s[k] for k in keys), ""))
        if self.batch is not None:  # the test days' fn factors exp(δ_g) (the sd is of δ_g, i.e. relative)
            for day, s in summary_of(self.batch.shifts, self.batch.days).items():
                rows.append((f"fn × {day or '(no day)'}", 1.0, math.exp(s["mean"]), s["sd"], math.exp(s["q05"]),
                             math.exp(s["q95"]), ""))
        header = ("parameter", "prior", "mean", "sd", "q05", "q95", "unit")
        return header, tuple(list(c) for c in zip(*rows))

    def modes(self) -> list[dict]:
        """The exchange modes with their share of samples and summaries (largest first); one entry when unimodal."""
        twin = split_modes(self.prior, self.samples, self.engine)
        if twin is None or min(twin.mean(), 1 - twin.mean()) < MODE_SHARE:
            return [{"label": "as tested", "share": 1.0, "parameters": summary(self.samples, self.names)}]
        out = []
        labels = ("as tested", "x<->y exchanged")
        if _symmetric(self.prior, self.engine):
            labels = ("x/y order of the first differing pair: x lower", "x/y order: x higher")  # a tie-broken split
        for label, mask in zip(labels, (~twin, twin)):
            out.append({"label": label, "share": float(mask.mean()),
                        "parameters": summary(self.samples[mask], self.names)})
        return sorted(out, key=lambda m: -m["share"])

    def parameters(self) -> dict:
        """Summaries of the main mode (all samples when unimodal)."""
        return self.modes()[0]["parameters"]

    def to_json(self) -> dict:
        modes = self.modes()
        warn = list(self.warnings)  # the bimodal one included (__post_init__)
        doc = {"schema": SCHEMA, "names": list(self.names), "units": self.prior.units(), "engine": self.engine,
               "parameters": modes[0]["parameters"], "modes": modes, "diagnostics": self.diagnostics,
               "warnings": warn, "warning_codes": [warning_code(w) for w in warn], "prior": self.prior.to_dict(),
               "cuts": self.cuts, "samples": self.samples.tolist(), **self.provenance}
        if self.noise is not None:
            names = list(self.prior.noise_names)
            doc["noise"] = {"names": names, "parameters": summary(self.noise, names), "samples": self.noise.tolist()}
        if self.batch is not None:
            doc["batch"] = self.batch.to_record()
        from millstab.points import describe_condition

        # "computed_for": the condition of every decision read from this file; "conditions": the trained ones,
        # with the exact angles [rad] that rebuild them (cuts["condition"] indexes them)
        doc["computed_for"] = describe_condition(self.prior.cutting)
        doc["conditions"] = [dict(describe_condition(c), entry=c.entry, exit=c.exit) for c in self.trained_conditions]
        if self.diameter_mm is not None:
            doc["diameter_mm"] = self.diameter_mm
        doc["engine_options"] = dict(self.engine_options)  # the discretisation every decision from this file uses
        return doc

    @classmethod
    def from_json(cls, doc: dict, source: str = "posterior") -> Posterior:
        """Rebuild a posterior from :meth:`to_json` output.

        Raises:
            InputError: not a millstab posterior (wrong or missing schema, bad samples).
        """
        if not isinstance(doc, dict) or doc.get("schema") not in (SCHEMA,) + OLD_SCHEMAS:
            got = doc.get("schema") if isinstance(doc, dict) else type(doc).__name__
            raise InputError(f"{source} schema", got, f"expected a posterior written by millstab update ({SCHEMA!r})")
        prior = Prior.from_dict(doc.get("prior") or {})
        s = np.asarray(doc.get("samples"), dtype=float)
        if s.ndim != 2 or s.shape[1] != prior.size or s.shape[0] < 2 or not (np.isfinite(s) & (s > 0)).all():
            raise InputError(f"{source} samples", f"shape {s.shape}",
                             f"need N ≥ 2 rows of {prior.size} finite values > 0")
        warn = tuple(str(w) for w in doc.get("warnings", ()))
        noise = None
        nd = doc.get("noise")
        if prior.noise_names and nd is not None:  # absent: the noise levels were held (e.g. prior draws)
            noise = np.asarray(nd.get("samples") if isinstance(nd, dict) else None, dtype=float)
            ok = (isinstance(nd, dict) and list(nd.get("names", ())) == list(prior.noise_names)
                  and noise.shape == (s.shape[0], len(prior.noise_names))
                  and np.isfinite(noise).all() and (noise > 0).all())
            if not ok:
                raise InputError(f"{source} noise", f"shape {noise.shape}",
                                 f"need {s.shape[0]} rows of the learned noise levels {list(prior.noise_names)} (> 0)")
        days = None
        if prior.batch_effect > 0 and doc.get("batch") is not None:  # absent: prior draws (no day seen yet)
            days = BatchPosterior.from_record(doc["batch"], s.shape[0], source)
        conditions = ()
        if doc.get("schema") == SCHEMA and doc.get("conditions"):  # /2 and /1: every cut in the prior's cutting
            from dataclasses import replace

            try:
                conditions = tuple(replace(prior.cutting, teeth=int(c["teeth"]), entry=float(c["entry"]),
                                           exit=float(c["exit"])) for c in doc["conditions"])
            except (KeyError, TypeError, ValueError):
                raise InputError(f"{source} conditions", doc["conditions"],
                                 "a list of {teeth, entry, exit [rad]} per trained condition") from None
            if len(conditions) == 1 and conditions[0] == prior.cutting:  # a one-condition posterior, as built
                conditions = ()
        dia = doc.get("diameter_mm")
        made_from = {"config": doc["config"]} if isinstance(doc.get("config"), str) else {}
        engine = doc.get("engine", "zoa")
        return cls(prior, s, engine, doc.get("diagnostics", {}), doc.get("cuts", {}), warn, noise, days, made_from,
                   conditions, None if dia is None else float(dia), _engine_options(doc, engine, source))


def _engine_options(doc: dict, engine: str, source: str) -> dict:
    """The discretisation a posterior document was fitted with: its ``engine_options``; in a file of the first
    version that had them, the diagnostics' copy; in an older file none (the engine's own choice). InputError
    for options its engine does not take."""
    from millstab.forward import engine_options

    given = doc.get("engine_options")
    if given is None:
        given = (doc.get("diagnostics") or {}).get("engine_options")
    if given is not None and not isinstance(given, dict):
        raise InputError(f"{source} engine_options", given, "a table of the engine's discretisation keywords")
    return dict(engine_options(engine, given, f"{source} engine_options"))


__all__ = ["MODE_SHARE", "OLD_SCHEMAS", "Posterior", "SCHEMA", "WARNING_CODES", "bimodal_warning", "warning_code",
           "exchange_of", "split_modes", "summary"]
