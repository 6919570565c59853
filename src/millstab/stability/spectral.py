"""Spectral-element collocation of the cutting intervals: an accurate and fast time-domain engine.

Same interface as :mod:`millstab.stability.zoa` and :mod:`millstab.stability.sdm` (``envelope``,
``envelope_batch``), plus :func:`monodromy`, :func:`rho_map` and the lobe type (Hopf / flip) in
:class:`SpectralEnvelope`. Modal structures only (as SDM); the force model is SDM's (see
:mod:`millstab.stability.sdm`): F = ½ b Kt [A(t)] (u(t) − u(t − T)).

Why this method (measured, see benchmarks/bench_spectral.py). The milling equation is a linear
delay equation with T-periodic coefficients; its stability is that of the monodromy operator over
one tooth period. Between cuts the tool vibrates freely, so the only part of the past that matters
is the displacement during the previous cut. This engine therefore discretises only the cutting
intervals, with spectral elements: each cutting segment (between entry/exit instants, where [A(t)]
is a smooth trigonometric function) is split into elements of at most ``ELEM_PERIODS`` natural
periods of the highest mode, and on each element the state is a polynomial of degree p collocated at
the p Gauss–Legendre points (order 2p at the element ends). The delayed displacement at a node is the
previous period's value at the same node, so no interpolation error enters; the free flight is one
exact exponential. The error falls spectrally with p (semi-discretization: O(h²)): 4 nodes per half
natural period give ρ to ~1e-5 on the benchmark, with a monodromy matrix of n + D·(nodes) = 6–20 rows
at a/D = 0.05, where SDM needs ~70 steps per period and a Richardson extrapolation (two grids). Measured
on the 1-DOF benchmark (201 speeds 5 000–25 000 rpm, down milling): within 0.17 % (a/D = 0.05), 0.12 %
(0.1), 0.17 % (0.5) and 0.37 % (slotting) of SDM's converged depths, flip speeds where SDM has them; up
milling within 0.24 %, except at 12 800 rpm (a/D = 0.5), where SDM steps over a flip band 3 % of the
depth wide that this engine finds (8 % lower; SDM's own ρ is unstable there). (The 0.47 % once quoted for
slotting at 23 000 rpm was a Hopf crossing 0.5 % below a flip one, missed.) The multi-frequency (Hill) form was not
chosen: at low immersion the directional matrix is a short pulse with jumps, whose Fourier series converges like 1/r, so
many harmonics (complex matrices of 2·(2h + 1) rows per direction) would be needed for 1 %, and its boundary needs a
search in frequency.

Accuracy control (converged by default). p = ``P_NODES`` Gauss nodes per element, elements ≤
``ELEM_PERIODS`` natural periods of the highest mode. Per call, before the batch is solved, the boundary
points of the first set at three check speeds (the lowest, where elements are longest, the middle and
the highest) are found with p nodes and moved by Newton to p + ``P_STEP`` nodes; while one moves by more
than ``TOL`` (0.1 %, ten times below the 1 % target) p grows by P_STEP (up to ``P_MAX``), and the
moved points are the start of the next check (a fresh search only where Newton failed). A problem
evaluated over many calls (identification, sensitivity: :class:`millstab.forward.Forward`) asks once,
through :func:`settings`, and passes ``nodes`` to every call: the finer of the two discretisations the check compared,
chosen at the first set of the problem's first call (a fit's start); a per-call check on each call's first set could
change p between the calls of one search (a jump of up to TOL in the objective). The fit re-checks at its solution and
polishes again where p changed there.

Root search (compiled, parallel over sets × speed blocks: a set's speeds are one block when the sets
fill the threads, else a few blocks of equal modelled cost, see ``_block_starts``). A
Floquet solution z(t + T) = μ z(t) has z(t − T) = z(t)/μ, so μ is a multiplier iff
det(μ I − Ψ(w (1 − 1/μ))) = 0, with Ψ(σ) the transition over one tooth period of the ODE
ż = (A0 + σ E(t) C) z (w = ½ b Kt): an n × n characteristic equation (n = 2 × modes), exact for the
discretised system too and far cheaper than the monodromy's eigenvalues. The boundary at a speed is
the smallest b with a multiplier e^{iθ} on the unit circle (θ = π: flip).
The search from below at one speed (the definition of the answer, SDM's with a coarser bottom): ρ(b) on the
ladder b_ref·LADDER (b_ref the zero-order depth at that speed; then ×1.5 up to 1e4·b_ref) up to the
first unstable depth, each ladder step refined into ``_spectral_kernel.REFINE`` parts (twice as many in
the ladder's coarse part below 0.6·b_ref, ``_spectral_kernel.refine_parts``) where it is
unstable or ρ at either end is within ``_spectral_kernel.NEAR`` (0.02) of 1 (a band narrower than the
ladder's step lies where a multiplier grazes the unit circle, so ρ is close to 1 beside it); Newton from
the bracket (θ from its dominant multiplier), Illinois on ρ − 1 where Newton fails.
Branch tracking proposes, that search disposes: every boundary root found (b, θ) is a branch (a lobe's
boundary, Hopf or flip), continued from speed to speed, up to ``_spectral_kernel.N_BRANCH`` at once, by
Newton on the characteristic function with its exact Jacobian (Ψ and dΨ/dσ from one LU per element,
Jacobi's formula; a flip root, where F(b, π) is real, in b alone), from a prediction linear in speed.
The lowest branch is accepted only if the search from below at this speed would not stop earlier: the
full monodromy is stable at every depth of it below b (and at b·(1 − 2e-3)); a failed depth brackets a
crossing below, Newton from inside it adds its root, checked in turn (the depths already found stable
are not evaluated again). So a speed's depth does not depend on which other speeds share the call
(issue 25: with acceptance rungs relative to the continued root, and a ladder around the previous
speed's depth after a lost branch, the 1 000 rpm grid of the 1-DOF benchmark at a/D = 0.5 gave
2.3498 mm at 10 000 rpm, a flip band 2.104–2.318 mm stepped over, +11.65 % against SDM, while a fine
grid gave 2.1040 mm; and a fine grid in up milling stepped over flip bands far below a rising Hopf
boundary: +465 %, +294 % and +39 % against SDM at a/D = 0.05, 0.1 and 0.5; tests/test_grid_independence.py).
A continued branch may still find a crossing below the search from below's (a root of the characteristic
equation is a true crossing: never above the first one), which the refinement near ρ = 1 makes rare:
on the benchmark's coarse, random and single-speed calls at every immersion the depths agree with a
fine grid's to < 1e-6 with the same nodes. Warm starts (:mod:`._spectral_warm`): a row within
``WARM_REL`` of the row heading its run (the rows of a finite-difference Jacobian) starts at that row's
boundary at each speed: Newton, then the same acceptance (a failed depth brackets the crossing below,
as above); only where that is not accepted is the speed searched from below. The accepted depths are
roots of the discretised characteristic equation to ~1e-12, so they are smooth in the parameters
(finite-difference Jacobians in identification). Limitation, as for every ladder: an unstable band
narrower than the ladder's step, beside which ρ stays below 1 − NEAR, can be missed (by SDM too). Known
case (x = y one mode each, benchmark modes, a/D = 0.05, 200 speeds 5 000–25 000 rpm): at 24 698 rpm a
dense ρ scan (:func:`rho_map`) shows an unstable island at 58–63 mm that both this engine and SDM
stepped over (both reported 80.5 mm before this search); such islands lie far above the lowest lobes (2–3
mm there).

Eigenvalues by a compiled QR (issue 28, 2026-11-27): ρ at every ladder depth is the spectral radius of
the reduced monodromy (10–30 rows), and LAPACK's dgeev spent ~70 % of that evaluation in its fixed costs;
:func:`._spectral_kernel.eig_small` (balance, Hessenberg, Francis double-shift QR) does it 2× faster. Same
search path (32.4 evaluations per speed before and after), depths within 3.7e-11 of dgeev's on 16 benchmark
cases (two structures, a/D 0.05–1, up and down milling, 101 speeds). Alternated with the code before in the
same minutes (load 19–21 on the 2 cores, so CPU time is the figure; ``PYTHONPATH=src:benchmarks python
benchmarks/bench_spectral.py --skip-accuracy --repeat 5``): CPU per 200-speed envelope on one thread 142.9 /
141.8 ms → 101.2 / 100.4 ms (1.41×), on two threads 174.1 / 166.2 → 129.2 / 124.6 ms (1.33×); about 10
envelopes/s per core. What remains (measured, :func:`._spectral_kernel.rho` on this benchmark): ~20 ladder
depths below the root at every speed, each a monodromy (~40 % of an evaluation now) and its eigenvalues;
certifying ρ < 1 without eigenvalues by ‖Uᵐ‖^{1/m} fails (the monodromy is far from normal: the bound
is 1.10–1.5× ρ at m = 64, below 0.98 at only 37 % of the depths where ρ is). The issue's 100 envelopes/s
needs fewer ρ evaluations per speed, which every ladder-based definition of the answer forbids.
Low-rank factors and certified rungs (issue 28, 2026-11-27). Where the time went (benchmarks/profile_spectral.py,
one thread, CPU, load ~17): on the update's workload (100 prior samples × 10 cut speeds of the docs/updating.md
case, 6 nodes, ``near`` 0) 35.6 evaluations per (set, speed), 21.2 of them ρ on the ladder rungs under the
accepted root (the floor every per-speed definition climbs); a ρ evaluation 30 µs (monodromy build 13.7 µs, its
eigenvalues 16.9 µs), a characteristic function with its derivative 25 µs, a speed's layout 3 µs; the
zero-order starting depths, the node-count check and Python < 5 % of a call. On the 200-speed envelope (x = y,
a/D 0.05) 31.7 evaluations per speed, 20.9 of them rungs; ρ 14.6 µs (build 7.0, eigenvalues 7.6). Three
changes, each keeping every decision of the search (depths and multipliers of both workloads and of the
benchmark at a/D 0.05 / 0.5 / 1, up and down, identical bit for bit to the code before the third, within
3.5e-11 of the code before the first two):
(1) sparse speeds searched alone (``PHASE_SPLIT``): 35.6 → 27.3 evaluations per (set, speed) of an update.
(2) per-speed low-rank factors (:func:`._spectral_kernel.low_rank_setup`): each element's collocation matrix
is L(w) = L0 − w B Cᵀ with a coupling of rank he (the element's history: the chip thicknesses at its
nodes) and right-hand side [R0 | −w B]; by Woodbury only W = (I − w S)⁻¹ (he × he, S = Cᵀ L0⁻¹ B) depends on
the depth, so the p·n-row LU per element and depth became one per element and speed plus an he × he solve
(:func:`._spectral_kernel.monodromy_lr`; the characteristic function's Ψ(σ) = Π (LA + σ LE W CA) and
dΨ/dσ from LE W² CA, :func:`._spectral_kernel.psi_d_lr`): build 13.7 → 1.9 µs, characteristic function
25 → 3.6 µs (tests/test_spectral_lowrank.py: the same matrices to 1e-9, ρ to 2.4e-12, on random structures,
cuts and node counts, also against the full monodromy's numpy eigenvalues).
(3) certified rungs (:func:`._spectral_kernel.rho_below`): with the eigenvalues now ~90 % of ρ, a rung is
decided without them where squarings of the balanced monodromy B prove ρ ≤ ‖Bᵐ‖∞^{1/m} < 1 (or < 1 − near),
rounding bounded; where a bracket is formed, ρ at its low end is computed exactly (the secant start and
Illinois steps see the values they saw before). ‖Bᵐ‖∞ < 1 held at 3 / 30 / 62 / 81 % of 4 221 rungs for m =
2 / 4 / 8 / 16 (20 prior samples × 10 cut speeds; ``_spectral_kernel.CERT_SQUARINGS`` = 6 squarings). Root
search on the update's workload 1.009 → 0.817 → 0.458 → 0.265 s CPU (3.8×). On the 200-speed envelope, CPU per
envelope on one thread 101.7 / 99.3 / 100.8 ms (the code before, in the same minutes, load ~14) → 54.9 / 54.3 ms
after (2) (two threads 128.7 / 125.8 / 125.7 → 81.8 / 80.2 ms); after (3), alternated with the code before at
load ~6: 99.8 / 98.6 → 47.1 / 47.6 ms (2.1×; two threads 123.5 / 126.7 → 75.4 / 73.0 ms), ~21 envelopes/s
per core (``PYTHONPATH=src:benchmarks python benchmarks/bench_spectral.py --skip-accuracy --repeat 5``).
Still far from the issue's 100/s: the ladder's ~21 rungs remain (ρ(0) is already 0.83–0.91 here, and
``near`` asks for ρ < 0.98, so fewer rungs are certified than in an update).
Cheaper rung tests (issue 28, 2026-11-27, :func:`._spectral_kernel.rho_test`). Where the 200-speed envelope's
time went after (3) (one thread, CPU, ``benchmarks/profile_spectral.py`` and a census of the rungs): 31.7
evaluations per speed, 20.9 of them rungs under the root (3 987 rungs on 200 speeds, K = 10–16 rows, mean 11); the
squarings certified 80 % of them (4.7 squarings each on average, a hand-written K³ loop of 0.43 µs per squaring at
K = 10) and the other 20 % paid six squarings and then the eigenvalues (5.3 µs; 7.3 % of the rungs have ρ above 1
− near, which triggers the refinement); the ~11 other evaluations per speed were mostly ρ at the refinement's inner
depths and at a checked root's top (each up to six squarings and the eigenvalues), ~4 Newton steps (2.5 µs) and a
speed setup with its low-rank factors (6.5 µs). Changed: a squaring is a BLAS product (0.15 µs); up to 10 of them
(ρ up to ~0.99 of the level is certified: the refinement's inner depths now mostly are); the bound is the smaller
of ‖Bᵐ‖∞ and ‖Bᵐ‖_F (81.5 % of the rungs within six squarings, ∞ alone 79.5 %); the squarings stop where the bound
stalls above the level (ρ is there) and are skipped at a rung whose rung below was above the level and at a checked
root's top (ρ within ~1e-3 of 1). No decision of the search changes (a bound decides only where it is below the
level, and a bracket's ends are exact, as before): on 18 envelopes (three structures, a/D 0.05 / 0.5 / 1, up and
down, 101 speeds) and a batch with warm rows, every depth and multiplier is bit for bit the code before's. CPU per
200-speed envelope on one thread, alternated with the code before in the same minutes (load ~23 on the 2 cores):
50.5 / 50.0 / 48.8 → 34.4 / 33.9 / 33.6 ms (1.46×), **~29 envelopes/s per core** (``PYTHONPATH=src:benchmarks
python benchmarks/bench_spectral.py --skip-accuracy --repeat 5``). The issue's 100/s is still 3.4× away: ~21 rung
decisions per speed are the definition's floor, and an exact ρ (the eigenvalues of a 10–16-row matrix) is 5–10 µs.
Measured and not kept: an eigenvector basis (of the rung below, or of the same rung at the previous speed) as the
similarity of the certificate: 35 % / 19 % of the rungs certified at one product (the balanced squarings: 80 %).
The rung test by its parts (issue 28, 2026-11-27; ``benchmarks/profile_spectral.py`` times each part on the real
rungs under the roots, one thread, CPU, load ~11). On the update's workload (100 prior samples × 10 cut speeds, K =
16.6 rows) a rung cost 5.65 µs: its monodromy build 1.9 µs (allocations are not the cost: built into preallocated
arrays it is the same), a full balance 0.9 µs (3.3 sweeps, 77 power-of-2 steps), 2.6 squarings each 0.2 µs in BLAS
plus 0.3 µs of norms whose single running sums were bound by the additions' latency, and the eigenvalues of the
3.7 % it does not certify (15.7 µs: QR 10.6, Hessenberg 1.7, balance 0.7). Changed, each keeping every value the
search uses: one workspace per speed (``_spectral_kernel.workspace``, g[9] of ``with_factors``: the build, the
squarings (``np.dot`` into it) and the eigenvalues reuse its arrays); the certificate's similarity is the speed's
last balancing scaling (its first depth's own, refreshed by every exact ρ) instead of a fresh balance (any
diagonal similarity bounds ρ; a stale one certifies as often: 96.3 % of the rungs, 2.64 squarings); the norms
keep four partial sums; the low-rank setup factors L0 once per element length (a segment's elements share it).
Where the certificate fails, the exact ρ balances the matrix itself, so every exact value is bit for bit the code
before's: every depth and multiplier of 16 workloads (150 prior samples × 10 speeds with and without ceilings, a
warm-start batch, 12 envelopes of two structures at a/D 0.05 / 0.5 / 1 up and down, 101 speeds, and the 200-speed
one) is identical; an evaluation count moves by one where a certificate now holds or no longer does (the bracket's
low end then made exact). A rung 5.65 → 4.4 µs (build 1.9 + certificate 2.4), a speed setup 11.5 → 9.9 µs; the
search 0.237 → 0.208 ms per (set, speed); the 200-speed envelope 31.8 → 29.0 ms CPU on one thread (same minutes,
load ~11: ~34 envelopes/s per core); the accurate update's root search (docs/updating.md, 300 samples) 2.01 / 2.04 →
1.72 / 1.74 s CPU, 1 000 samples 6.46 → 5.77 s. What remains per (set, speed) of the update: 21.2 rungs (44 %), the
setup (5 %), and 9.3 other evaluations (~51 %, ~11 µs each: the refinement's depths near ρ = 1, the bracket's ends and a
checked root's top, mostly exact ρ at ~16 µs, and ~2.9 Newton steps of 3.6 µs). Measured and not kept: a
certificate at a checked root's top (ρ there 0.9974–0.9996, median 0.9991, on 200 roots): 16 squarings certify 51
of them, after 8–10 squarings each; the QR's update loops split on their loop-invariant branch: 10.6 → 10.2 µs,
within the noise; the build's sums reordered along rows (the same sums in the same order): no gain measured.
A censored search (issue 28, 2026-11-27): :func:`envelope_batch`'s ``ceiling`` (B, S) stops a speed's search from
below once every depth of it up to one at or above the ceiling is stable and returns that depth, a certified lower
bound of the limit (``_spectral_kernel.scan_to``'s ``cap``); below the ceiling every depth is the limit. For a
likelihood whose terms no longer move above it (:meth:`millstab.update.likelihood.Likelihood.ceilings`): 31.3 → 26.6
evaluations per (set, speed) in the 300-sample update of docs/updating.md, the same particles bit for bit.
A sampler's node count (issue 28, 2026-11-27): :func:`settings` with ``purpose="sample"`` gives the
converged count (checked from P_NODES + P_STEP up) instead of a fit's converged + P_STEP; the updating loop
asks for it (:data:`millstab.update.likelihood.SAMPLING`), its likelihood comparing depths with a noise of
several %. Measured (benchmarks/bench_spectral_nodes.py, 100 prior samples × 10 cut speeds of the
docs/updating.md case, a reference 4 nodes above the fit's 8): 6 nodes within 0.16 % of the depth (0.031
σ_b) at 0.6× the fit count's CPU; 4 nodes land on another root at 6.6 % of the pairs (hence the start at 6).
Measured and not kept (same day, 20 prior samples × 10 cut speeds, 4 227 ladder rungs below the root):
certifying a rung stable without its eigenvalues by a Lyapunov matrix P of another rung (P − MᵀPM ≻ 0 by
one Cholesky, on the balanced monodromy; unbalanced, no rung is certified: ‖P‖ ~ 3e7): the previous
rung's P certifies 68 % of the rungs, a P kept until it fails 51 %; but each P is a Lyapunov solve
(a Schur form, dearer than the eigenvalues), so neither scheme saves work.
A coarse bottom of the ladder (issue 28, 2026-11-28; ``_spectral_kernel.refine_parts``). The rungs under 0.6·b_ref are
the cheapest of a search (ρ far below 1: a build and two or three squarings, ~4 µs) but six of its ~31 evaluations;
below 0.6 the ladder now takes every other one of SDM's rungs (0.1, 0.2, …, 0.6 × b_ref), and a coarse step where the
refinement is due (ρ above 1 − NEAR at either end, or its top unstable) is refined into 2·REFINE parts, which visit the
fine ladder's rung and refinement depths between its ends. So the two ladders can differ only where a band narrower
than 0.1·b_ref lies under 0.6·b_ref with ρ below 1 − NEAR at both coarse rungs and a fine rung inside it or beside it
above 1 − NEAR. Measured against the code before (random prior draws of ex1, ex2, ex3 and fourflute at a/D 0.02 /
0.05 / 0.1 / 0.25 / 0.5, up and down, 40 speeds in 1 000–40 000 rpm, and Ex.1 at a/D 0.1 in 5 000–12 000 rpm, 6
nodes: 175 960 (set, speed) pairs; ``benchmarks/bench_spectral_ladder.py`` re-measures it, the code before being
this kernel with ``sdm.FACTORS`` as its ladder): every limit the same within 3.8e-13, 7.5–19.4 % fewer evaluations
(Ex.1 and fourflute 16–19 %, ex2 and ex3 8–13 %). Refined into REFINE parts only, the coarse steps had missed one
band in about 210 000 such pairs (ex3 at a/D 0.05 up, 34 491 rpm: 7.22 mm against 6.71, a band at 0.28·b_ref), which the
2·REFINE parts find (6.71 mm, the same as before). Coarse up to 0.8·b_ref (2·REFINE parts too) saved 15.2 % of the
evaluations against 12.7 % but missed a band in the same pairs (Ex.1 at a/D 0.1: 29.10 mm against 24.85, at
0.6–0.8·b_ref): not taken. ``tests/test_spectral_fast.py`` re-computes both definitions in plain numpy. Measured
and not kept (same pairs): a rung whose certificate below 1 − NEAR fails but whose squarings bound ρ below 1 taken as
stable and refined without its eigenvalues: every limit the same bit for bit, but 2.6 % more evaluations (the
refinements it adds) and no CPU saved.
Speed since the grid-independent acceptance (issue 25; 200 speeds, x = y one mode each, a/D = 0.05,
benchmarks/bench_spectral.py, alternated with the code before on the shared machine, load ~15 on 2
cores, so CPU times are the figure): 32.4 evaluations per speed (was 11.5), CPU per envelope 165–170 ms
on two threads (was 75–83 ms), 137 ms on one (was 51–54 ms): about 2.1–2.6× slower. Where it goes:
~20 ladder depths below the root at every speed (the root lies at ~1.1 b_ref here, the ladder steps by
0.05 b_ref), ~8 for the refinement near ρ = 1 (ρ(0) = e^{−ζωT} is 0.83–0.91 here, so ρ is near 1 over
much of the ladder), ~4 characteristic functions (Newton). The relative rungs it replaces were cheap
because they did not check what the search from below checks; a continued root cannot skip that check
without making the depth depend on the grid. Measured and not kept: screening the ladder on p − 2 or
p − 1 nodes (ρ off by up to 0.46 and 0.04 on random benchmark speeds, and only 41 % of the depths below
0.9); skipping depths by the previous speed's ρ there (|Δρ| per 100 rpm step up to 0.21 where the
zero-order depth jumps between lobes). Figures before it (same benchmark) follow.
Earlier (200 speeds, x = y one mode each, a/D = 0.05; the 2-core machine
is shared, so old (the code before) and new ran alternately in the same minutes, BLAS pinned to one
thread, best of 7 per run, three pairs each). Two threads: wall 29.7–30.5 ms, 33 envelopes/s (old
44.5–51.8 ms, 19–22/s), CPU 58 ms per envelope (old 74–87 ms); one thread: 48.7 ms CPU (old 60.0–60.8).
What changed: (1) the speeds are split into blocks of equal modelled cost (``_speed_cost``: the
monodromy's rows × (1 + the phase step of the flexible mode between neighbouring speeds), one block
per thread for one set: split at 46 of 200 here, where the first 20 speeds, 5 000–6 900 rpm, cost as
much as the last 100), where the previous equal-length blocks (4 × 50) left one thread idle most of
the time: 40 → 28 ms wall in a measurement of the root search alone on the idle machine; (2) ρ on the
reduced monodromy (10 rows instead of 16 with one element, 16 instead of 28 with two: −25 to −38 % CPU of the
root search); (3) a branch moving down by > 25 % is no longer searched from below (−2 % evaluations).
The rising-flank rungs (a correctness fix) cost back +17 % evaluations (11.5 per speed, was 9.8). The
zero-order guesses now cost 0.2 ms per call (the zero-order engine got faster), the convergence check
~4 ms. What bounds it now (one thread, 45 ms for the root search): ~170 speeds where the branch simply
continues cost ~7 evaluations (3 ρ, or 6 under a rising boundary, and ~3.5 characteristic functions
of 14–25 µs), ~100 µs each; the ~30 speeds where the boundary's branch is lost or jumps up (lobe
changes, crowded below 9 000 rpm where each 100 rpm step turns the flexible mode's phase by 0.3–0.7
rad) cost 21–27 evaluations each, about 40 % of the total; on two threads the CPU time rises 49 → 58
ms (a second block start and the idle thread's wait). 100 envelopes/s would need both fewer
evaluations at lobe changes (a continuation that follows a lobe's end onto the next one) and cheaper
acceptance than ρ rungs. Measured and not kept: the lower rungs and the ladder on a coarser
discretisation (p − 2 or p − 1 nodes, redone at p where ρ > 0.98–0.99): at a/D = 0.05 the coarse ρ is
off by up to 0.05 near the boundary (colliding flip multipliers), so the flip band at 12 538 rpm was
missed (p − 1 too); accepting another tracked branch with the search-from-below's rungs where the
boundary's branch was lost (+1 % evaluations); skipping lower rungs when the previous speed's margin
was large (ρ at a rung moves by up to 0.05 per speed step while the margins are often < 0.05);
rising-flank rungs only above a 5 % rise (−4 % evaluations, one more band missed). Earlier figures
(before these changes): root search 58 ms CPU on one thread, 1 951 evaluations. Measured and not
kept then: a single check at 0.995 (misses the island at 24 799 rpm: 93.1 mm instead of 59.1 mm).
Branch tracking also found a flip band the previous scheme missed: at 12 538 rpm (same case) the boundary
is a flip at 14.80 mm, not the Hopf crossing at 15.10 mm it reported (tests/test_spectral.py).
Identification (benchmarks/bench_spectral_identify.py --engines spectral: Example 1, a/D = 0.1, 40 SDM
points, the same global search as the zero-order engine, seed 0). Why the evaluation count varied (5 834
here, 2 501 with an older engine): it is set by the path of the global search, which on these points either
escapes a wrong basin (RMS log residual 4–5.5 %) in its first stage or only later, and 0.1 %-level
differences in the depths decide which. Measured with the same engine and the node count per call (the
earlier scheme: 4 for the screening, 6 from the first LM steps on; p switched between calls only there and
once near the end, so the jumps of hypothesis "p per call" were not the cause): 5 834 evaluations, the truth
found in the second re-seeding round; p fixed at 6: 6 308, found only by the confidence-region stage; p
fixed at 4 (the start's converged count): 8 500 evaluations and the wrong basin (79 % off). Now the search
runs on the discretisation chosen once (:func:`settings`: 6 here, re-checked at the solution: 8, one more
polish) and the finite-difference rows start warm: 2 663 evaluations (the truth found in the first stage),
every parameter within 0.12 % (RMS log residual 7.7e-4); the kernel's evaluations per cold (set, speed) are
~19 at these sparse speeds (a ladder at most speeds), per warm one ~5 (Newton, three checks). Timed
alternately with the previous code on the shared machine (load 7–13, 2 cores): old 409.7 s (5 834
evaluations, 70 ms each) against new 130.3 s (2 663, 49 ms), and again 523.9 s (90 ms) against 176.5 s (66
ms): 3.0–3.1× in all, 1.35–1.45× per evaluation, and 2.2× fewer evaluations (the screening now runs at p =
6, not 4). With the faster kernel merged (reduced monodromy, cost-balanced blocks), on the idle machine
(load ~1.9, 2026-11-23 22:46): **26.8 s**, 2 544 evaluations, 10.5 ms each, every parameter within 0.121 %
(the issue's < 60 s and 0.5 %); what remains is mostly cold searches (the 513-set screening). The
zero-order engine on the same points: 0.2 s, off by up to 83 % (the damping ratios; k 12–15 %).
With issue 25's grid-independent acceptance (2026-11-27) and the refinement near ρ = 1 on, the same
benchmark ended in a wrong basin:
4 984 evaluations, 288.8 s at load 3–5, ζ_x 76 % and ζ_y 57 % off, RMS log residual 5.5e-2 (the code before,
minutes earlier at load ~15: 2 544, 119.3 s, 0.121 %). The depths at the truth are unchanged (the 40
points agree with the code before's to the digit, with 6 and 8 nodes), so the minimum is where it was;
the path of the global search changed (depths elsewhere in the box, where bands are now found, differ).
With the refinement near ρ = 1 off (``_spectral_kernel.NEAR`` = 0: the ladder alone, refined only in its
unstable step) the fit is back: 0.121 %, 2 615 evaluations, 182.5 s (load 3–5): the refinement's narrow
bands, found or not as the parameters move, make the objective rough. So :func:`settings` (what a
problem evaluated over many calls passes to every call) turns it off: 0.121 %, 2 615 evaluations,
135.9 s (load ~4, tests running beside it); the per-speed acceptance stays.
Earlier measurements without gain: reusing the previous speed's Newton Jacobian, elements of one
natural period (3× faster in slotting, but 0.9 % off, too close to the 1 % target).

Lobe type and chatter frequency: the critical multiplier μ = e^{iθ} at the boundary; θ = π
(|arg μ| > π − FLIP_ARG) is a period-doubling (flip) boundary, otherwise Hopf. The chatter frequency
(±arg μ + 2πk)/T is taken nearest the most flexible mode's natural frequency, as in SDM; lobe =
floor(f_c T) (whole vibration waves per tooth period).

Units: rpm at the interface, depth in m (``depth_mm`` for mm), frequencies in Hz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from threadpoolctl import ThreadpoolController, threadpool_limits

from millstab.errors import InputError
from millstab.frf import ModalBatch
from millstab.model import Cutting, Structure
from millstab.stability import _spectral_kernel as _k
from millstab.stability import _spectral_warm as _w
from millstab.stability import zoa
from millstab.stability.sdm import FACTORS, _arrays, _chatter_hz, _require_modal, _static_scale
from millstab.stability.base import Envelope, memory_chunk_rows
from millstab.stability.base import by_condition, check_ceiling, check_floor, check_kr, check_rpm, kr_sets
from millstab.stability.process_damping import reject as _reject_process_damping

#: collocation nodes per element (degree of the polynomial) before the convergence check
P_NODES = 4
#: nodes added per refinement of the convergence check, and the most allowed
P_STEP = 2
P_MAX = 16
#: the longest element, in natural periods of the highest mode
ELEM_PERIODS = 0.5
#: relative depth change between p and p + P_STEP accepted as converged (the target is 1 %)
TOL = 1e-3
#: relative width of the final root bracket
RTOL = 2e-4
#: the search from below's ladder (multiples of the zero-order depth, ascending; then ×1.5 per step): SDM's
#: (``sdm.FACTORS``) from 0.6 up, every other one of its rungs below (``_k.refine_parts``: a coarse step is refined into
#: twice the parts, on SDM's rungs and the fine refinement's depths), and every accepted root is checked against it
#: (``_k.check_root``)
LADDER = np.concatenate([FACTORS[1:10:2], FACTORS[11:]])  # 0.1, 0.2, …, 0.5; then SDM's from 0.6
#: the shortest block of the root search (blocks run in parallel; within one, branches continue): a
#: block start costs a full ladder search, so a set is split only to keep the threads busy
BLOCK = 25
#: a speed starts a block of its own (no branch continued into it) where the most flexible mode's phase turns by
#: more than this [rad] between its tooth period and the previous speed's (:func:`_phase_steps`): the branches
#: continued across such a step are mostly lost (a lobe change at nearly every step), and each lost one cost up to
#: 2 × ``_spectral_kernel.NEWTON_EVALS`` characteristic functions before the search from below ran anyway. The
#: depths do not change (each speed's acceptance is its own): measured (issue 28, 2026-11-27, one thread, CPU)
#: on 100 prior samples × 10 cut speeds of the docs/updating.md case (steps of 1–3 rad): 35.6 → 27.2 evaluations
#: per (set, speed), −21 % CPU, depths within 1.2e-11; the 1-DOF benchmark x = y at a/D 0.05 / 0.5 on 50 speeds
#: 5 000–25 000 rpm −17 % / −8 % CPU, on 200 speeds −4 % / ±1 % (thresholds 0.5 and 1.0 gave less)
PHASE_SPLIT = 0.3
#: tasks (set × block) per thread at most when the sets alone do not fill the threads: blocks are of
#: equal modelled cost (``_speed_cost``), so one per thread balances one set; ``_blocks_per_set``
BLOCKS_PER_THREAD = 2
#: rows within this largest |ln ratio| of (ωn, ζ, m) of their run's head start from its boundary (warm
#: starts, :func:`_solve_warm`): the rows of a finite-difference Jacobian differ by ~1e-4
WARM_REL = 1e-2
#: the search from below refines a ladder step where ρ is within NEAR of 1 (``_spectral_kernel.scan_to``);
#: :func:`settings` turns it off (0) for a problem evaluated over many calls, see the docstring
NEAR = _k.NEAR
#: a multiplier within this angle [rad] of the negative real axis marks a flip boundary
FLIP_ARG = 1e-3
#: a floor (:func:`envelope_batch`'s ``floor``) is tested at a (set, speed) only where the zero-order depth there is at
#: most this multiple of the floor (inf: everywhere). A test that does not floor costs an exact ρ (~16 µs) where the
#: rung it stands for would mostly have been certified (~4 µs). Measured (issue 28, 2026-11-28, the 1 000-sample update
#: of docs/updating.md, its 26 root searches replayed 5 times alternated, ``bench_update_accurate.py --samples 1000
#: --floor-replay 5 --floor-gate 1,0.9,inf``, load ~4 on 2 cores): without floors 554 950 evaluations, 3.90 s CPU
#: (min); gate inf 16 400 tests, 1 500 floored, 526 402 evaluations, 3.88 s; 1.0: 1 900 tests, 1 356 floored,
#: 514 515, 3.59 s; 0.9: 517 321, 3.54 s (0.7: fewer floored, more evaluations than 0.9)
FLOOR_GATE = 1.0
#: a cutting whose directional matrix is constant over the tooth period (``Cutting.time_invariant``: a slot with 4, 6,
#: 8 … teeth) is solved by the zero-order engine: its boundary is then exact, not an average, and a collocation of the
#: whole period (every instant cut: ~60 rows of monodromy, ~10× the ρ cost of a/D 0.1) only approximates it. Measured
#: (2026-11-29, the seed paper's four-flute tool, slot, 40 speeds 5 000–20 000 rpm): the collocated depths within
#: 2.4e-6 of the zero-order ones, 2.5 s against 0.016 s. False: collocate it anyway (the engine's own tests)
INVARIANT_BY_ZOA = True

__all__ = ["envelope", "envelope_batch", "envelope_batch_hz", "monodromy", "rho_map", "SpectralEnvelope", "P_NODES",
           "ELEM_PERIODS", "TOL"]


@dataclass(frozen=True, eq=False)
class SpectralEnvelope(Envelope):
    """:class:`~millstab.stability.zoa.Envelope` plus the lobe type and the critical multiplier.

    Attributes:
        kind: ``"hopf"``, ``"flip"`` or ``"none"`` (no boundary) per speed (S,).
        multiplier: the critical Floquet multiplier e^{iθ} at the boundary (S,) complex (NaN where none).
        nodes: collocation nodes per element the convergence check settled on (0: none; a time-invariant cutting is
            solved by the zero-order model, exact there, :data:`INVARIANT_BY_ZOA`).
    """

    kind: np.ndarray = None  # type: ignore[assignment]
    multiplier: np.ndarray = None  # type: ignore[assignment]
    nodes: int = P_NODES


def _w_flex(batch: ModalBatch) -> np.ndarray:
    """ωn [rad/s] of each set's most flexible mode (largest 1/(k ζ)): the chatter frequency is taken nearest it."""
    fn = np.concatenate([batch.fn_x, batch.fn_y], axis=1)
    kz = np.concatenate([batch.k_x * batch.zeta_x, batch.k_y * batch.zeta_y], axis=1)
    return np.ascontiguousarray(2 * math.pi * fn[np.arange(batch.size), np.argmin(kz, axis=1)])


def _cut_args(cutting: Cutting) -> tuple:
    return cutting.teeth, cutting.kt, cutting.kr, cutting.entry, cutting.exit


def _elem_len(wn: np.ndarray) -> np.ndarray:
    """Longest element [s] per set: ELEM_PERIODS natural periods of its highest mode."""
    return np.ascontiguousarray(ELEM_PERIODS * 2 * math.pi / wn.max(axis=1))


def _b_ref(batch: ModalBatch, cutting: Cutting, r: np.ndarray, kr: np.ndarray | None = None) -> np.ndarray:
    """Zero-order depths (B, S) [m] as the search's starting guess (a finite stand-in where it has none); ``kr`` (B,)
    or None: as :func:`envelope_batch`."""
    b_ref = zoa.envelope_batch(batch, cutting, r, kr=kr)
    fallback = np.where(np.isfinite(b_ref), b_ref, np.nan)
    row_max = np.nanmax(np.where(np.isfinite(fallback), fallback, -np.inf), axis=1)
    row_max = np.where(np.isfinite(row_max), row_max, _static_scale(batch, cutting))
    return np.ascontiguousarray(np.where(np.isfinite(b_ref), b_ref, row_max[:, None]))


def _blocks_per_set(n_b: int, n_threads: int) -> int:
    """Blocks per set: the fewest (each block start costs a search from below) that give every thread
    the same number of (cost-balanced) tasks, or at least BLOCKS_PER_THREAD tasks per thread."""
    k = 1
    while (n_b * k) % n_threads and n_b * k < BLOCKS_PER_THREAD * n_threads:
        k += 1
    return k


def _phase_steps(batch: ModalBatch, cutting: Cutting, rs: np.ndarray) -> np.ndarray:
    """The phase [rad] the most flexible mode (mean ωn over the sets) turns through between the tooth periods of
    each speed and the one before it (S,; the first speed: the step to a speed below it as far as the next one)."""
    T = 60.0 / (cutting.teeth * rs)
    dT = np.abs(np.diff(T, prepend=T[0] + (T[0] - T[1] if T.size > 1 else 0.0)))
    return float(np.mean(_w_flex(batch))) * dT


def _speed_cost(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, p: int) -> np.ndarray:
    """A model of the root search's cost per speed (S,), for load balance: the monodromy's rows K (its
    collocation elements grow as the cut lasts longer at low speed) times (1 + φ/0.1), φ [rad] the
    phase the most flexible mode turns through between the tooth periods of neighbouring speeds
    (capped at 0.3: beyond it nearly every speed is a lobe change). Measured on the benchmark (x = y,
    a/D = 0.05, 200 speeds 5 000–25 000 rpm, 1 thread): 0.65, 0.45, 0.20 and 0.155 ms per speed near
    6 000, 8 000, 12 000 and 20 000 rpm; the model gives 4.9 : 2.6 : 1.5 : 1."""
    phase = _phase_steps(batch, cutting, rs)
    omega = 2 * math.pi * rs / 60.0
    cut = min(cutting.exit - cutting.entry, 2 * math.pi / cutting.teeth) / omega
    wn = _arrays(batch)[0]
    n_col = np.ceil(cut / float(np.min(_elem_len(wn))) - 1e-9)
    rows = 2 * wn.shape[1] + 2 * p * n_col
    return rows * (1.0 + np.minimum(phase, 0.3) / 0.1)


def _block_starts(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, p: int) -> np.ndarray:
    """Start indices of the speed blocks (ends with S): the whole range per set when the sets fill the
    threads (no restarts), else :func:`_blocks_per_set` blocks of equal modelled cost
    (:func:`_speed_cost`: the low speeds cost several times more), none shorter than BLOCK; and a block of its
    own at every speed more than PHASE_SPLIT of phase from the speed before (sparse speeds: the cut speeds of
    an update)."""
    n_s = rs.size
    # a speed whose tooth period turns the flexible mode's phase by more than PHASE_SPLIT from the speed before
    # starts a block of its own: continuing branches across such a step mostly fails (Newton on every tracked
    # branch, then the search anyway), see PHASE_SPLIT
    far = np.flatnonzero(_phase_steps(batch, cutting, rs) > PHASE_SPLIT) if n_s > 1 else np.zeros(0, np.int64)
    k = min(_blocks_per_set(batch.size, numba.get_num_threads()), math.ceil(n_s / BLOCK))
    if k <= 1:
        return np.unique(np.concatenate([[0], far, [n_s]])).astype(np.int64)
    cum = np.cumsum(_speed_cost(batch, cutting, rs, p))
    cuts = np.searchsorted(cum, cum[-1] * np.arange(1, k) / k)
    shortest = min(BLOCK, n_s // k)
    cuts = np.clip(cuts, shortest, n_s - shortest)
    return np.unique(np.concatenate([[0], cuts, far, [n_s]])).astype(np.int64)


#: the threadpoolctl controller of :func:`_one_blas_thread`, made once
_BLAS: list = []


def _one_blas_thread():
    """A context holding BLAS to one thread while the compiled search runs (its numba threads call BLAS products:
    nested threads would oversubscribe the cores). The controller is made once: ``threadpool_limits(1)`` scans every
    loaded library at each call, ~1–2 ms (issue 28: 35 engine calls per 300-sample update)."""
    if not _BLAS:
        import scipy.linalg.cython_blas  # noqa: F401  the BLAS numba's np.dot calls: loaded before the scan

        _BLAS.append(ThreadpoolController())
    return _BLAS[0].limit(limits=1)


def _solve(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, b_ref: np.ndarray, p: int,
           block: int | None = None, near: float = NEAR, ceiling: np.ndarray | None = None,
           floor: np.ndarray | None = None, kr: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """Depth, multiplier and evaluation counts (B, S) at ascending speeds rs with p nodes per element
    (speeds in blocks of ``block``, default :func:`_block_starts`; branches continue within a block);
    ``ceiling`` (B, S) [m]: a censored search (:func:`envelope_batch`), None: none; ``floor`` (B, S) [m]: the
    floors (:func:`envelope_batch`; ≤ 0 or None: none), tested where b_ref ≤ FLOOR_GATE × the floor; ``kr`` (B,):
    each set's Kr (None: the cutting's)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    n_b, n_s = batch.size, rs.size
    if block is None:
        starts = _block_starts(batch, cutting, rs, p)
    else:
        starts = np.unique(np.concatenate([np.arange(0, n_s, block), [n_s]])).astype(np.int64)
    depth = np.empty((n_b, n_s))
    mu = np.empty((n_b, n_s), dtype=np.complex128)
    n_eval = np.empty((n_b, n_s), dtype=np.int64)
    n, kt, _, ps, pe = _cut_args(cutting)
    cap = np.full((n_b, n_s), np.inf) if ceiling is None else np.ascontiguousarray(ceiling, dtype=float)
    low = np.zeros((n_b, n_s)) if floor is None else np.ascontiguousarray(floor, dtype=float)
    krs = kr_sets(cutting, kr, n_b)
    with _one_blas_thread():
        _k.limit_batch(n, kt, krs, ps, pe, rs, starts, b_ref, LADDER, float(near), wn, zeta, mass, mdir, act,
                       _elem_len(wn), _k.gauss_nodes(int(p)), RTOL, _w_flex(batch), depth, mu, n_eval, cap, low,
                       float(FLOOR_GATE))
    if np.any(np.isnan(depth)):
        raise ArithmeticError("spectral engine: root search produced NaN")
    return depth, mu, n_eval


def _heads(wn: np.ndarray, zeta: np.ndarray, mass: np.ndarray,
           kr: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Rows that start from a nearby row's boundary: (follower mask (B,), head index (B,)).

    A run of consecutive rows, each within ``WARM_REL`` (largest |ln ratio| of ωn, ζ, m) of the row
    before, follows the run's first row (its head) if also within WARM_REL of it: the layout of
    finite-difference rows ([u, u + h e_1, ...], :func:`millstab.forward.fd_rows`); with a Kr per set (B,), within
    WARM_REL in ln(1 + Kr) too (Kr may be 0). Vectorised: no per-row work in Python."""
    cols = [wn, zeta, mass] if kr is None else [wn, zeta, mass, (1.0 + kr)[:, None]]
    par = np.log(np.concatenate(cols, axis=1))
    near_prev = np.zeros(par.shape[0], bool)
    near_prev[1:] = np.max(np.abs(np.diff(par, axis=0)), axis=1) < WARM_REL
    head = np.maximum.accumulate(np.where(near_prev, 0, np.arange(par.shape[0])))
    follow = near_prev & (np.max(np.abs(par - par[head]), axis=1) < WARM_REL)
    return follow, head


def _solve_warm(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, b_ref: np.ndarray, p: int,
                near: float = NEAR, ceiling: np.ndarray | None = None,
                floor: np.ndarray | None = None, kr: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """:func:`_solve` with warm starts: rows near the row heading their run (:func:`_heads`) start at
    the head's boundary (Newton, then the checks, :mod:`._spectral_warm`); the heads and every other row
    are searched cold, and so is every (row, speed) where the warm start is not accepted (that speed
    alone, from below). Depth, multiplier, evaluations (B, S). ``ceiling``, ``floor``: the cold rows' censored search
    and floors (:func:`_solve`); the warm rows have neither. ``kr`` (B,): each set's Kr (None: the cutting's)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    follow, head = _heads(wn, zeta, mass, kr)
    if not follow.any():
        return _solve(batch, cutting, rs, b_ref, p, near=near, ceiling=ceiling, floor=floor, kr=kr)
    cold = np.flatnonzero(~follow)
    sub = ModalBatch(*(getattr(batch, f)[cold] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    depth = np.empty((batch.size, rs.size))
    mu = np.empty((batch.size, rs.size), dtype=np.complex128)
    n_eval = np.empty((batch.size, rs.size), dtype=np.int64)
    krs = kr_sets(cutting, kr, batch.size)
    depth[cold], mu[cold], n_eval[cold] = _solve(sub, cutting, rs, np.ascontiguousarray(b_ref[cold]), p, near=near,
                                                 ceiling=None if ceiling is None else ceiling[cold],
                                                 floor=None if floor is None else floor[cold], kr=krs[cold])
    row = np.flatnonzero(follow)
    n, kt, _, ps, pe = _cut_args(cutting)
    nd = _k.gauss_nodes(int(p))
    el = _elem_len(wn)
    e_shape = (row.size, rs.size)
    d_w, th_w, ok, ne_w = np.empty(e_shape), np.empty(e_shape), np.empty(e_shape, bool), np.empty(e_shape, np.int64)
    b0 = np.ascontiguousarray(depth[head[row]])
    th0 = np.ascontiguousarray(np.abs(np.angle(mu[head[row]])))
    with _one_blas_thread():
        _w.warm_batch(n, kt, krs, ps, pe, rs, row, b0, th0, np.ascontiguousarray(b_ref[row]), LADDER, float(near), wn,
                      zeta, mass, mdir, act, el, nd, d_w, th_w, ok, ne_w)
        e, s = np.nonzero(~ok)
        if e.size:  # the warm start not accepted: that speed searched from below, from the zero-order depth
            i = row[e]
            d_c, mu_c, ne_c = np.empty(e.size), np.empty(e.size, dtype=np.complex128), np.empty(e.size, np.int64)
            _w.cold_entries(n, kt, krs, ps, pe, rs, i.astype(np.int64), s.astype(np.int64),
                            np.ascontiguousarray(b_ref[i, s]), LADDER, float(near), wn, zeta, mass, mdir, act, el, nd,
                            RTOL, _w_flex(batch), d_c, mu_c, ne_c)
    depth[row] = d_w
    mu[row] = np.exp(1j * th_w)
    n_eval[row] = ne_w
    if e.size:
        depth[row[e], s], mu[row[e], s], n_eval[row[e], s] = d_c, mu_c, n_eval[row[e], s] + ne_c
    if np.any(np.isnan(depth)):
        raise ArithmeticError("spectral engine: root search produced NaN")
    return depth, mu, n_eval


def _moved(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, depth: np.ndarray, mu: np.ndarray,
           p: int, kr: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Set 0's boundary points (depth (S,) [m], multiplier (S,)) at speeds rs, moved by Newton to the
    discretisation with p nodes (NaN where Newton fails: not converged; inf stays inf); ``kr``: set 0's Kr (None:
    the cutting's)."""
    wn, zeta, mass, act, mdir = _arrays(batch)
    n, kt, kr_c, ps, pe = _cut_args(cutting)
    kr = kr_c if kr is None else float(kr)
    nd = _k.gauss_nodes(int(p))
    el = float(_elem_len(wn)[0])
    d_new = np.full(rs.size, np.nan)
    mu_new = np.full(rs.size, np.nan, dtype=np.complex128)
    for i in range(rs.size):  # a handful of check speeds, not a hot loop
        if not np.isfinite(depth[i]):
            d_new[i], mu_new[i] = depth[i], mu[i]
            continue
        b, th, ok, _ = _k.refine_at(n, kt, kr, ps, pe, float(rs[i]), float(depth[i]), float(abs(np.angle(mu[i]))),
                                    wn[0], zeta[0], mass[0], mdir, act, el, nd)
        if ok:
            d_new[i], mu_new[i] = b, complex(math.cos(th), math.sin(th))
    return d_new, mu_new


def _check_speeds(n_s: int) -> np.ndarray:
    """Indices of the convergence-check speeds: the lowest (longest elements), the middle and the highest."""
    return np.unique([0, n_s // 2, n_s - 1])


def _converged_nodes(batch: ModalBatch, cutting: Cutting, rs: np.ndarray, b_ref: np.ndarray, p0: int = P_NODES,
                     kr: np.ndarray | None = None) -> int:
    """The convergence check: nodes per element for set 0 of ``batch`` at ascending speeds rs (b_ref its
    zero-order depths (B, S) [m]; ``kr`` (B,) or None: each set's Kr). Set 0's boundary points at the check speeds
    are moved by Newton to p + P_STEP nodes; while one moves by more than TOL (or Newton fails), p grows by P_STEP
    (from p0)."""
    p = p0
    idx = _check_speeds(rs.size)
    sub = ModalBatch(*(getattr(batch, f)[:1] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    kr0 = None if kr is None else kr[:1]
    # each check speed is its own block: they are far apart, continuation between them only fails
    d_c, mu_c, _ = (a[0] for a in _solve(sub, cutting, rs[idx], b_ref[:1, idx], p, block=1, kr=kr0))
    while p < P_MAX:
        d_n, mu_n = _moved(sub, cutting, rs[idx], d_c, mu_c, p + P_STEP, None if kr is None else float(kr[0]))
        with np.errstate(invalid="ignore"):
            moved = np.where(np.isinf(d_c) & np.isinf(d_n), 0.0, d_n / d_c - 1)
        if np.all(np.abs(moved) <= TOL):
            break
        p += P_STEP
        if np.all(np.isfinite(moved)):
            # the moved points are the boundary at p nodes: the next check starts from them (a
            # root search per check speed saved)
            d_c, mu_c = d_n, mu_n
        else:  # Newton failed somewhere: search afresh at p nodes
            d_c, mu_c, _ = (a[0] for a in _solve(sub, cutting, rs[idx], b_ref[:1, idx], p, block=1, kr=kr0))
    return p


def _limit(batch: ModalBatch, cutting: Cutting, r: np.ndarray, nodes: int | None,
           warm: bool = True, near: float = NEAR, ceiling=None, floor=None,
           kr=None) -> tuple[np.ndarray, np.ndarray, int]:
    """Limiting depths (B, S) [m] and critical multipliers (B, S) at speeds r (any order); the nodes used.

    With ``nodes=None`` the convergence check runs first, on set 0 at the check speeds only: their
    boundary points are moved by Newton to p + P_STEP nodes; while one moves by more than TOL (or Newton
    fails), p grows by P_STEP. Then the whole batch is solved once with that p. ``ceiling``, ``floor``, ``kr``: see
    :func:`envelope_batch`.
    """
    if nodes is not None and (isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or nodes < 2):
        raise InputError("nodes", nodes, "collocation nodes per element must be an integer >= 2 (or None)")
    _reject_process_damping(cutting, name)
    if isinstance(near, bool) or not isinstance(near, (int, float, np.floating)) or not 0.0 <= near < 1.0:
        raise InputError("near", near, "the refinement margin near rho = 1 must be a number in [0, 1)")
    if _by_zoa(cutting):
        depth, mu = _invariant(batch, cutting, r, check_kr(kr, batch.size))
        return depth, mu, 0
    # solved once per distinct speed, in increasing order (the continuation from speed to speed needs a
    # step > 0: repeated speeds made the kernel divide by zero), then put back in the caller's order
    rs, inv = np.unique(r, return_inverse=True)
    rs = np.ascontiguousarray(rs)
    cap = _ceiling(ceiling, batch.size, r.size, inv, rs.size)
    low = _floor(floor, batch.size, r.size, inv, rs.size)
    kr = check_kr(kr, batch.size)
    b_ref = _b_ref(batch, cutting, rs, kr)
    p = _converged_nodes(batch, cutting, rs, b_ref, kr=kr) if nodes is None else int(nodes)
    depth, mu, _ = (_solve_warm if warm else _solve)(batch, cutting, rs, b_ref, p, near=near, ceiling=cap, floor=low,
                                                     kr=kr)
    return depth[:, inv], mu[:, inv], p


def _by_zoa(cutting: Cutting) -> bool:
    """Whether ``cutting`` is handed to the zero-order engine (:data:`INVARIANT_BY_ZOA`): one rule for the depths
    (:func:`_limit`) and the discretisation (:func:`settings`)."""
    return INVARIANT_BY_ZOA and cutting.time_invariant


def _invariant(batch: ModalBatch, cutting: Cutting, r: np.ndarray, kr: np.ndarray | None
               ) -> tuple[np.ndarray, np.ndarray]:
    """Limiting depths (B, S) [m] and critical multipliers (B, S) of a time-invariant cutting
    (:data:`INVARIANT_BY_ZOA`) from the zero-order engine: the delay equation then has constant coefficients, its
    boundary is the zero-order one, and the multiplier of the chatter frequency f_c is e^{2πi f_c T} (NaN where no
    boundary). A ceiling or floor is not needed: every depth is the limit itself (their contracts allow it)."""
    depth, hz = zoa.envelope_batch_hz(batch, cutting, r, kr=kr)
    T = 60.0 / (cutting.teeth * r)
    ok = np.isfinite(depth) & np.isfinite(hz)
    mu = np.where(ok, np.exp(2j * math.pi * np.where(ok, hz, 0.0) * T), complex(np.nan, np.nan))
    return depth, mu


def _ceiling(ceiling, n_b: int, n_s: int, inv: np.ndarray, n_distinct: int) -> np.ndarray | None:
    """The censored search's caps (B, S distinct speeds) [m] from the caller's (B, S) ``ceiling`` (None: none): a
    repeated speed takes its largest. InputError for another shape or a value that is NaN or not positive."""
    c = check_ceiling(ceiling, n_b, n_s)
    if c is None:
        return None
    cap = np.full((n_b, n_distinct), -np.inf)
    np.maximum.at(cap.T, inv, c.T)
    return cap


def _floor(floor, n_b: int, n_s: int, inv: np.ndarray, n_distinct: int) -> np.ndarray | None:
    """The floors (B, S distinct speeds) [m] from the caller's (B, S) ``floor`` (None: none): a repeated speed takes
    its smallest (≤ 0: none there). InputError for another shape or a NaN."""
    f = check_floor(floor, n_b, n_s)
    if f is None:
        return None
    low = np.full((n_b, n_distinct), np.inf)
    np.minimum.at(low.T, inv, f.T)
    return low


def lobe_kind(mu: np.ndarray) -> np.ndarray:
    """``"flip"`` for a multiplier on the negative real axis, ``"hopf"`` otherwise, ``"none"`` if NaN."""
    mu = np.asarray(mu)
    flip = np.abs(np.angle(mu)) > math.pi - FLIP_ARG
    return np.where(~np.isfinite(mu), "none", np.where(flip, "flip", "hopf"))


def envelope(structure: Structure, cutting: Cutting, rpm, nodes: int | None = None) -> SpectralEnvelope:
    """The limiting depth b_lim [m] at each spindle speed [rpm] for one modal structure.

    ``inf`` where no boundary exists up to 1e4 times the reference depth. ``nodes``: collocation
    nodes per element (None: chosen by the convergence check, see the module docstring).

    Raises:
        InputError: for a measured-FRF structure (the time-domain engines need modal parameters).
    """
    _require_modal(structure)
    r = check_rpm(rpm)
    depth, mu, p = _limit(ModalBatch.from_structures([structure]), cutting, r, nodes)
    flex = max(structure.modes, key=lambda m: 1.0 / (m.k * m.zeta))
    T = 60.0 / (cutting.teeth * r)
    ok = np.isfinite(depth[0])
    hz = np.where(ok, _chatter_hz(mu[0], T, flex.fn), np.nan)
    lobe = np.where(ok, np.floor(np.nan_to_num(hz) * T), -1).astype(np.int64)
    kind = np.where(ok, lobe_kind(mu[0]), "none")
    return SpectralEnvelope(r, depth[0], lobe, hz, kind=kind, multiplier=mu[0], nodes=p)


@by_condition
def envelope_batch(batch: ModalBatch, cutting: Cutting, rpm, nodes: int | None = None,
                   near: float = NEAR, warm: bool = True, ceiling=None, floor=None, kr=None) -> np.ndarray:
    """Limiting depths (B, S) [m] for B modal parameter sets at S spindle speeds [rpm]. ``near``: the search
    from below refines a ladder step where ρ is within ``near`` of 1 (``NEAR``; 0: only its unstable step,
    which a problem's :func:`settings` asks for). ``warm``: rows within ``WARM_REL`` of the row heading their
    run start from its boundary (:func:`_heads`; for finite-difference Jacobians). A warm row can land on a
    crossing below the one its own search from below finds (a band narrower than the ladder's step), so its
    depth can depend on its neighbour: a sampler, whose likelihood must be one function of θ, turns it off
    (:func:`settings` with ``purpose="sample"``); not a discretisation option (``forward.NOT_OPTIONS``).

    ``ceiling`` (B, S) [m] (a censored search; None or inf: none; one Cutting only, not per-column conditions):
    where every depth of the search from below up to one at or above ``ceiling`` is stable, the search stops
    there and returns that depth, a certified lower bound of the limit (≥ the ceiling), instead of the limit. For
    a caller that needs only "above the ceiling" there (a likelihood whose terms no longer change above it,
    :meth:`millstab.update.likelihood.Likelihood.ceilings`); below it every depth is the limit itself.

    ``floor`` (B, S) [m] (None, or ≤ 0 at an entry: none there; one Cutting or per-column conditions): where the
    search from below's highest ladder rung x_k at or below 0.997 × the floor (:func:`._spectral_kernel.floor_rung`)
    is unstable (exact ρ > 1), the limit is below x_k/0.998 < the floor and x_k itself is returned (no search);
    elsewhere the limit, the same bits as without a floor. For a caller that needs only "below the floor" there (a
    likelihood whose terms no longer change below it: :meth:`millstab.update.likelihood.Likelihood.floors`). The
    test runs only where the zero-order depth is at most :data:`FLOOR_GATE` × the floor.

    ``kr`` (B,) (None: the cutting's): each set's radial-to-tangential ratio, overriding the cutting's Kr (the
    ``per_set_kr`` capability: a sampler that learns Kr). The kernel builds each (set, speed)'s directional factors
    anyway, so a Kr per set costs nothing; the depths are those of one call per set with its own Kr, bit for bit."""
    r = check_rpm(rpm)
    return _limit(batch, cutting, r, nodes, warm=warm, near=near, ceiling=ceiling, floor=floor, kr=kr)[0]


@by_condition
def envelope_batch_hz(batch: ModalBatch, cutting: Cutting, rpm, nodes: int | None = None,
                      near: float = NEAR, warm: bool = True, kr=None, ceiling=None,
                      floor=None) -> tuple[np.ndarray, np.ndarray]:
    """Limiting depths (B, S) [m] and chatter frequencies (B, S) [Hz] for B modal parameter sets at S
    spindle speeds [rpm]: the critical multiplier's frequency nearest each set's most flexible mode
    (largest 1/(kζ), x before y on a tie), as :func:`envelope` reports for one structure; NaN where
    no boundary exists. ``near``, ``warm``, ``kr``, ``ceiling``, ``floor``: as :func:`envelope_batch`; an entry whose
    depth is a censored one (at or above its ceiling) or a floored one (below its floor) has no boundary found, so its
    frequency is NaN (a likelihood that reads a column's frequency gives that column neither: issue 28)."""
    r = check_rpm(rpm)
    depth, mu, _ = _limit(batch, cutting, r, nodes, warm=warm, near=near, kr=kr, ceiling=ceiling, floor=floor)
    bounded = np.zeros(depth.shape, bool)
    with np.errstate(invalid="ignore"):
        if ceiling is not None:
            bounded |= depth >= np.broadcast_to(np.asarray(ceiling, float), depth.shape)
        if floor is not None:
            bounded |= depth < np.broadcast_to(np.asarray(floor, float), depth.shape)
    mu = np.where(bounded, complex(np.nan, np.nan), mu)
    k = np.concatenate([batch.k_x, batch.k_y], axis=1)
    fn = np.concatenate([batch.fn_x, batch.fn_y], axis=1)
    zeta = np.concatenate([batch.zeta_x, batch.zeta_y], axis=1)
    flex = np.argmax(1.0 / (k * zeta), axis=1)
    f_ref = fn[np.arange(batch.size), flex][:, None]
    hz = np.where(np.isfinite(depth), _chatter_hz(mu, 60.0 / (cutting.teeth * r), f_ref), np.nan)
    return depth, hz


def monodromy(structure: Structure, cutting: Cutting, rpm: float, depth_m: float, nodes: int = P_NODES) -> np.ndarray:
    """The monodromy matrix over one tooth period at one speed [rpm] and depth [m]; its eigenvalues
    are the Floquet multipliers (the cut is stable when all have modulus < 1)."""
    _require_modal(structure)
    _reject_process_damping(cutting, name)
    wn, zeta, mass, act, mdir = _arrays(ModalBatch.from_structures([structure]))
    r = float(check_rpm([rpm])[0])
    n, kt, kr, ps, pe = _cut_args(cutting)
    x, Dm, lend = _k.gauss_nodes(int(nodes))
    g = _k.setup(n, kr, ps, pe, r, float(_elem_len(wn)[0]), x, wn[0], zeta[0], act)
    return _k.monodromy(float(depth_m), kt, wn[0], zeta[0], mass[0], mdir, act.size, g[0], g[1], g[2], g[3], g[4], Dm,
                        lend)


def rho_map(structure: Structure, cutting: Cutting, rpm, depth_m, nodes: int | None = None) -> np.ndarray:
    """Spectral radius ρ of the monodromy matrix on a speed × depth grid, shape (S, D) (depths in m).

    ``nodes``: collocation nodes per element; None (the default) converges them: from P_NODES up by P_STEP
    (to P_MAX) until no ρ of the grid moves by more than TOL. Why not a fixed count: the limits' search converges
    its nodes on the boundary, where ρ = 1, but deep inside a band a coarse collocation can put ρ on the wrong side
    of 1 (Example 1 at a/D 0.05 down, 12 500 rpm, 145 mm, a stable pocket above a flip band: 4 nodes 1.022,
    6 nodes 0.9527, 8 and more 0.9530; SDM at 400 steps 0.9526)."""
    r = check_rpm(rpm)
    d = np.atleast_1d(np.asarray(depth_m, dtype=float))
    if d.ndim != 1 or not np.all(np.isfinite(d)) or np.any(d < 0):
        raise InputError("depth_m", depth_m, "depths must be a 1-D list of finite values >= 0 m")
    if nodes is not None:
        return _rho_grid(structure, cutting, r, d, int(nodes))
    p, out = P_NODES, _rho_grid(structure, cutting, r, d, P_NODES)
    while p < P_MAX:
        p += P_STEP
        finer = _rho_grid(structure, cutting, r, d, p)
        done = np.max(np.abs(finer - out)) <= TOL
        out = finer
        if done:
            break
    return out


def _rho_grid(structure: Structure, cutting: Cutting, r: np.ndarray, d: np.ndarray, nodes: int) -> np.ndarray:
    """ρ on the (speed, depth) grid at ``nodes`` collocation nodes per element."""
    out = np.empty((r.size, d.size))
    with threadpool_limits(1):
        for i, s in enumerate(r):  # a diagnostic, not a hot path
            for j, b in enumerate(d):
                out[i, j] = np.max(np.abs(np.linalg.eigvals(monodromy(structure, cutting, s, b, nodes))))
    return out


# -- the engine contract (millstab.stability.base.Engine) -----------------------------------------
name = "spectral"
#: the time-domain model keeps the time-varying forces, so the zero-order x↔y exchange is not exact
exact_xy_exchange = False
#: modal structures only (the state-space model needs fn, k, ζ per mode)
accepts_measured_frf = False
#: ``kind`` per speed: hopf / flip / none
reports_lobe_type = True
reports_progress = False
cheap = True
#: the process-damping term is not carried yet (a cut with it is an InputError naming the engines that do)
process_damping = False
#: :func:`envelope_batch_hz` gives the critical multiplier's frequency beside the depth
reports_chatter_frequency = True
time_averaged = False
#: :func:`envelope_batch` takes a ``ceiling`` (a censored search: a certified lower bound above it)
takes_ceiling = True
#: :func:`envelope_batch` takes a ``floor`` (a floored search: a depth below it where the limit is below it)
takes_floor = True
#: ``envelope_batch(..., kr=(B,))``: each (set, speed)'s directional factors are built in the kernel anyway
per_set_kr = True
#: relative accuracy of a limiting depth (the final root bracket; the node count converges to TOL)
depth_accuracy = RTOL
#: sets per call for callers that stream many sets: as large as the zero-order engine's, because each
#: call runs the node-count convergence check once (on its first set), so fewer calls cost less and
#: give every set the same node count
CALL_ROWS = 16_384


#: what a problem's :func:`settings` asks of the node count: ``"fit"`` the converged count + P_STEP (a search
#: over a box of parameters differentiates the depths, see :func:`settings`); ``"sample"`` the converged
#: count, checked from P_NODES + P_STEP up (a sampler compares depths with a depth noise of several %:
#: measured on the docs/updating.md case, 100 prior samples × 10 cut speeds,
#: benchmarks/bench_spectral_nodes.py, the converged count's depths are within 0.16 % (0.03 σ_b) of a
#: reference with 6 more nodes, at 0.6× the CPU time of the "fit" count)
PURPOSES = ("fit", "sample")


@by_condition
def settings(batch: ModalBatch, cutting: Cutting, rpm, purpose: str = "fit") -> dict:
    """The discretisation for a whole problem (optional contract capability, see
    :class:`millstab.stability.base.Engine`): ``{"nodes": p + P_STEP}``, p the node count the convergence
    check settles on for set 0 of ``batch`` at speeds ``rpm`` [rpm] (p + P_STEP its reference), to pass to every later
    :func:`envelope_batch` call, so the depths of one problem are one smooth function of the parameters
    (a per-call check can change p between calls, a jump of up to TOL); and ``"near": 0``: the ladder refined
    only in its unstable step, because narrow bands found by the refinement near ρ = 1 appear and vanish as
    the parameters move (measured: the identification benchmark then ended in a wrong basin, module
    docstring); the depth of each speed still does not depend on the other speeds. ``purpose`` ``"sample"``
    (:data:`PURPOSES`): the converged count itself, for a sampler whose likelihood compares depths with a
    depth noise of several % (the updating loop), never below P_NODES + P_STEP, with the refinement near ρ = 1 on
    (``NEAR``) and ``"warm": False``."""
    if purpose not in PURPOSES:
        raise InputError("purpose", purpose, "one of " + ", ".join(PURPOSES))
    _require_modal_batch(batch)
    if _by_zoa(cutting):  # no collocation to discretise (_limit); merged with the others'
        return {}
    rs = np.ascontiguousarray(np.unique(check_rpm(rpm)))
    first = ModalBatch(*(getattr(batch, f)[:1] for f in ("fn_x", "k_x", "zeta_x", "fn_y", "k_y", "zeta_y")))
    # the finer of the two discretisations the check compared: a whole search moves the parameters, and
    # p converged at set 0 alone was measured too coarse elsewhere in the box (Example 1 at a/D = 0.1:
    # 4 at the start, 6 at the truth, 8 at fn × 1.2)
    if purpose == "fit":
        return {"nodes": _converged_nodes(first, cutting, rs, _b_ref(first, cutting, rs)) + P_STEP, "near": 0.0}
    # the check starts one step up: P_NODES nodes for every prior sample landed on another root (> 1 % off)
    # at 6.6 % of the (sample, speed) pairs (bench_spectral_nodes.py), and a first row can pass the check
    # at P_NODES (Example 1's identification start did)
    # and no warm starts between rows: a sampler's likelihood must be one function of θ, and a warm row's depth
    # can depend on its neighbour (envelope_batch; 1 of 12 000 pairs of rows within 0.4 % at a/D 0.1 differed by
    # 0.9 %, test_spectral_sampling); particles are seldom within WARM_REL of each other, so it costs nothing.
    # The refinement near ρ = 1 on (NEAR): a sampler does not differentiate the depths, so the identification's
    # reason to turn it off does not apply, and without it the search steps over narrow unstable bands (4 of
    # 12 000 (set, speed) pairs at a/D 0.1: a limit 11 % high, test_spectral_sampling); 1.02-1.12x the CPU of an
    # accurate update (bench_update_accurate.py --near 0)
    return {"nodes": _converged_nodes(first, cutting, rs, _b_ref(first, cutting, rs), P_NODES + P_STEP), "near": NEAR,
            "warm": False}


def _require_modal_batch(batch) -> None:
    if not isinstance(batch, ModalBatch):
        raise InputError("structure", type(batch).__name__, "a modal parameter batch (ModalBatch)")


def chunk_rows(n_speeds: int) -> int:
    """Parameter sets per ``envelope_batch`` call for ``n_speeds`` speeds (≤ CALL_ROWS, bounded memory)."""
    return memory_chunk_rows(n_speeds, CALL_ROWS)


import sys as _sys  # noqa: E402

from millstab.stability import register as _register  # noqa: E402

_register(_sys.modules[__name__])
