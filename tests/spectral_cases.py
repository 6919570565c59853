"""Random modal structures and cuts the spectral engine's tests share (one copy, not one per test file)."""

from __future__ import annotations

from millstab.model import Cutting, Mode, Structure


def random_case(rng) -> tuple[Structure, Cutting]:
    """A random structure (1–2 modes per direction, both directions 70 % of the time, else x only: 400–3 000 Hz,
    5–50 N/µm, ζ 0.005–0.08) and cut (1–4 teeth, Kt 0.3–2 GPa, Kr 0.1–0.5, a/D 0.03–1, up or down milling)."""
    m = int(rng.integers(1, 3))

    def modes():
        return tuple(Mode(rng.uniform(400, 3000), rng.uniform(5e6, 5e7), rng.uniform(0.005, 0.08)) for _ in range(m))

    structure = Structure(x=modes(), y=modes()) if rng.random() < 0.7 else Structure(x=modes())
    cut = Cutting.from_immersion(int(rng.integers(1, 5)), rng.uniform(3e8, 2e9), rng.uniform(0.1, 0.5),
                                 rng.uniform(0.03, 1.0), "down" if rng.random() < 0.5 else "up")
    return structure, cut
