"""How the studies write their figures down: the CSV tables and the Markdown reports of the
convergence study, the stability study and the benchmark (results/convergence, results/stability,
results/bench). The measuring is in convergence.py, stability.py and bench.py."""
from __future__ import annotations

from orchestrate.parameters import ORDER


def number(value) -> str:
    if isinstance(value, float):
        return f"{value:.3e}" if value and (abs(value) < 1e-2 or abs(value) >= 1e4) else f"{value:.4g}"
    return str(value)


def reproduce(command: str) -> list[str]:
    return ["Reproduce (from the repository root):", "", "```sh", command, "```", ""]


# --- convergence ----------------------------------------------------------------------------

QUANTITIES = ("errorV", "errorZeta", "errorBeta")
LABELS = {"errorV": "‖u − u_ref‖_V", "errorZeta": "‖ζ − ζ_ref‖_L2", "errorBeta": "‖β − β_ref‖_L2(Γ_C)"}


def expected_order(kind: str, scheme: str | None) -> float:
    """Theorem 2.1 of the seed: c(h^{3/4} + k) for the paper's scheme; the time schemes' own orders."""
    return ORDER.get(scheme or "euler", 1) if kind == "time" else 0.75


def convergence_report(table: list[dict], observed: dict[str, dict], command: str, studied) -> str:
    """The convergence study's README: per ladder its errors and the observed rates (`observed`:
    ladder → quantity → {"reference", "successive"})."""
    lines = ["# Convergence study", "", *reproduce(command),
             "Errors are maxima over the shared instants of the distance to the reference (*rel. V error at T*: "
             "‖u(T) − u_ref(T)‖_V/‖u_ref(T)‖_V, at the last instant alone); *next* is the distance "
             "to the next finer level. The reference of the lockstep and space ladders is their finest level; the "
             "time ladders, one per scheme on one mesh, share one reference run: the most accurate scheme listed "
             "at twice their finest N. Norms as in Theorem 2.1 of the seed: ‖·‖_V = (Σ_ℓ ∫ ε:ε)^½ for u, L² for ζ "
             "on the bodies and for β on Γ_C. Nested structured meshes make every norm exact (edp/tools/errors.edp); "
             "on meshes that are not nested (a graded family) each run's strains are evaluated at the reference mesh's "
             "quadrature points, and the reference triangles across its element edges err a little in each figure. The instants are each ladder's coarsest level's, shared by its levels.",
             "",
             "Reading the rates: an error against a reference is biased low next to it, because the reference has "
             "an error of its own, so rates against the reference can come out high at the fine end; distances "
             "between successive levels decay at the true rate. Both are given, over the finest three levels "
             "measured. Theorem 2.1 of the seed predicts at least h^{3/4} in space and k in time for the paper's "
             "scheme with P1 displacements (with space.order = 2 in the command above, P2: the solution's "
             "singularities, at the corners and where the contact ends, bound its rate as well); the orders of "
             "semi-implicit (1) and bdf2 (2) are expected (docs/model.md §9), not proved. A level "
             "that did not run says why (refused: its step exceeds a bound of an explicit term; stopped: it broke "
             "an invariant).", ""]
    for ladder in studied:
        rows = [row for row in table if row["ladder"] == ladder.name]
        lines += [f"## {ladder.name}", ""]
        if ladder.reference:
            reference = ladder.reference
            lines += [f"Reference: {reference.get('time.scheme', 'the scene scheme')} with N = {reference['time.N']} on "
                      f"the same mesh.", ""]
        lines += ["| n1 | n2 | N | " + " | ".join(LABELS[q] for q in QUANTITIES)
                  + " | rel. V error | rel. V error at T | next V | next ζ | next β | solver s |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for row in rows:
            if row["status"] != "ran":
                lines.append(f"| {row['n1']} | {row['n2']} | {row['N']} | did not run: {status_text(row['status'])} "
                             "| | | | | | | | |")
                continue
            values = [row.get(key) for key in ("errorV", "errorZeta", "errorBeta", "relativeErrorV", "relativeErrorVAtT",
                                               "nextV", "nextZeta", "nextBeta")]
            cells = ["reference" if "errorV" not in row else "–" if v is None else number(v) for v in values]
            lines.append(f"| {row['n1']} | {row['n2']} | {row['N']} | " + " | ".join(cells) + f" | {row['seconds']:.1f} |")
        size = "k" if ladder.kind == "time" else "h"
        order = expected_order(ladder.kind, ladder.scheme or (rows[0]["scheme"] if rows else None))
        lines += ["", f"Observed rates in {size} over the finest three levels measured (expected: {size}^{order:g}):", ""]
        for quantity in QUANTITIES:
            pair = observed[ladder.name][quantity]
            lines.append(f"- {LABELS[quantity]}: {rate_text(pair['reference'])} against the reference, "
                         f"{rate_text(pair['successive'])} from successive differences")
        lines.append("")
    return "\n".join(lines)


def rate_text(rate: float) -> str:
    return "n/a (fewer than two levels)" if rate != rate else f"{rate:.2f}"


def status_text(error: str) -> str:
    """A failed run's message without its exit-code prefix: which bound refused it, or what it broke."""
    message = error.split("): ", 1)[-1] if "FreeFem++ exit" in error else error
    return message.replace("|", "/")


# --- stability ------------------------------------------------------------------------------

def bracket(row: dict) -> str:
    """The columns a stability table shares: predicted | observed (bracket) | difference | N | T."""
    return (f"{row['predicted']:.5g} | {row['observed']:.5g} ({row['stableK']:.5g} – {row['unstableK']:.5g}) | "
            f"{100 * row['difference']:+.2f} % | {row['stableN']} | {row['T']:.4g}")


def certain_bound(row: dict) -> float:
    """2/(ρ + ρ_τ) from an elastic row's 2/ρ and 2/ρ_τ: below it the step is stable for certain."""
    return 2 / (2 / row["predicted"] + 2 / row["glueBound"])


def glue_columns(row: dict) -> str:
    """2/ρ_τ and the certain bound 2/(ρ + ρ_τ), for an elastic row run with tangential glue."""
    if not row["glueBound"]:
        return "– | –"
    return f"{row['glueBound']:.4g} | {certain_bound(row):.5g}"


def within_theory(row: dict) -> bool:
    """Does the observed bracket [stableK, unstableK] meet [2/(ρ + ρ_τ), min(2/ρ, 2/ρ_τ)]?"""
    return row["stableK"] <= min(row["predicted"], row["glueBound"]) and row["unstableK"] >= certain_bound(row)


def stability_report(rows: list[dict], command: str) -> str:
    """The stability study's README: predicted and observed bounds of the explicit terms, per
    time scheme, and the implicit schemes' runs far above the paper's scheme's bound."""
    by_term = {term: [row for row in rows if row["term"] == term]
               for term in ("elastic", "implicit elasticity", "damage source", "tangential glue", "normal glue")}
    lines = ["# Stability of the explicit terms, per time scheme: predicted and observed bounds", "",
             *reproduce(command),
             "Observed: the smallest stable N by bisection over a horizon T = max(5, 200 × the predicted bound) "
             "where the data are steady (unstable: the run stops on divergence, or it grows: ‖u‖_V(T) > "
             "10 ‖u‖_V(1) with the loads held after t = 1, or ζ farther from its equilibrium at T than at the "
             "start); the threshold lies between T/N and T/(N − 1), whose midpoint is given. The bounds and "
             "their derivations: docs/model-choices.md, \"Stability\", \"Explicit glue\" and \"Time schemes\".", ""]
    lines += elastic_section(by_term["elastic"])
    lines += implicit_section(by_term["implicit elasticity"])
    lines += source_section(by_term["damage source"])
    lines += glue_section(by_term["tangential glue"])
    lines += normal_glue_section(by_term["normal glue"])
    return "\n".join(lines) + "\n"


def elastic_section(elastic: list[dict]) -> list[str]:
    if not elastic:
        return []
    lines = ["## Elastic term (euler)", "",
             "The paper's scene on coarse meshes (body 1 with 6 elements per side, body 2 with 8) with E varied "
             "in both bodies. Predicted: k* = 2/ρ, ρ = max(bG/η, (2aG + bG)/(2μ + η)) (docs/model.md §7, "
             "edp/lib/stability.idp). With damage on, ζ < 1 lowers the effective ρ, so an unstable step can be "
             "masked; λ_u = 0 keeps ζ = 1. The scene's tangential glue (p_τ = 1) adds its own bound 2/ρ_τ; "
             "the true threshold lies between 2/(ρ + ρ_τ) and min(2/ρ, 2/ρ_τ) (docs/model-choices.md, "
             "\"Explicit glue\"), which matters where ρ_τ is not small against ρ (soft bodies).", "",
             "| E/η | damage | predicted k* | observed k* (bracket) | difference | smallest stable N | T | 2/ρ_τ | 2/(ρ + ρ_τ) |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {row['parameter']:.3g} | {'on' if row['damage'] == 'on' else 'λ_u = 0'} | {bracket(row)} | "
              f"{glue_columns(row)} |" for row in elastic]
    undamaged = [row for row in elastic if row["damage"] == "off"]
    worst = max(abs(row["difference"]) for row in undamaged)
    lines += ["", f"Largest difference with λ_u = 0: {100 * worst:.2f} %."]
    with_glue = [row for row in undamaged if row["glueBound"]]
    if with_glue:
        inside = sum(within_theory(row) for row in with_glue)
        lines += [f"With λ_u = 0, {inside} of {len(with_glue)} observed brackets meet the theory's interval "
                  "[2/(ρ + ρ_τ), min(2/ρ, 2/ρ_τ)]."]
    return lines + [""]


def implicit_section(implicit: list[dict]) -> list[str]:
    if not implicit:
        return []
    lines = ["## The implicit schemes far above k*, with strong damage", "",
             "semi-implicit and bdf2 have no elastic bound (docs/model-choices.md, \"Time schemes\"). The same scene "
             "and horizons as above, with λ_u raised (column λ_u) so that ζ falls far below 1 and reaches the "
             "obstacle ζ = 0 (the weakening (1 − ζ)G is then as large as G, and bdf2's extrapolated ζ* is clipped), "
             "run at k = m k*. *checks*: the driver's divergence and chatter checks; *growth*: the largest "
             "‖u‖_V(tⁿ)/‖u‖_V(tⁿ⁻¹) once the loads are held (damage softens the bodies, so a stable run grows "
             "too, boundedly); *ζ = 0*: the fraction of nodes at the obstacle at T; *difference*: ‖u(T)‖_V "
             "against bdf2 at k*/16 on the same mesh — a time error, not an instability; *reference check*: "
             "‖u(T)‖_V of the paper's scheme at k*/16 against that reference; *ζ < ζc*: when ζ first fell below "
             "the level ζc under which the explicit damage source is unstable (run.json `zetaBelowCriticalStep`), "
             "which the obstacle masks where ζ is held at 0 but not above it.", "",
             "| scheme | E/η | λ_u | k/k* | N | T | checks | growth | min ζ(T) | ζ = 0 | ζ < ζc from t = | difference | reference check |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for row in implicit:
        below = "never" if row.get("zetaBelowCriticalAt") is None else f"{row['zetaBelowCriticalAt']:.4g}"
        measured = (f"{row['growth']:.3g} | {max(row['zetaMin'], 0.0):.3g} | {100 * row['zetaZeroFraction']:.0f} % | "
                    f"{below} | {100 * row['normVDifference']:+.2f} %" if row["checks"] == "passed" else "– | – | – | – | –")
        lines.append(f"| {row['scheme']} | {row['parameter']:.3g} | {row['lambdaU']:.3g} | {row['kOverKStar']:.3g} | "
                     f"{row['stableN']} | {row['T']:.4g} | {row['checks']} | {measured} | "
                     f"{100 * row['referenceCheck']:+.3f} % |")
    passed = sum(row["checks"] == "passed" for row in implicit)
    lines += ["", f"{passed} of {len(implicit)} runs passed the driver's checks."]
    return lines + [""]


def measured_bound_section(title: str, description: str, parameter: str, predicted: str, rows: list[dict],
                           digits: str) -> list[str]:
    """A table of predicted against observed step bounds, one row per scheme and parameter value."""
    if not rows:
        return []
    lines = [f"## {title}", "", description, "",
             f"| scheme | {parameter} | {predicted} | observed (bracket) | difference | smallest stable N | T |",
             "|---|---|---|---|---|---|---|"]
    lines += [f"| {row['scheme']} | {row['parameter']:{digits}} | {bracket(row)} |" for row in rows]
    worst = max(abs(row["difference"]) for row in rows)
    return lines + ["", f"Largest difference: {100 * worst:.2f} %.", ""]


def source_section(source: list[dict]) -> list[str]:
    return measured_bound_section(
        "Damage source",
        "The paper's scene without loads (u = 0) and with λ_u = 0, λ_D = 1, λ_w = −9: a uniform ζ obeys "
        "ζ' = λ_D (1 − ζ)/ζ + λ_w, with its equilibrium ζ_eq = 0.1; started at 0.101. Linearized, the explicit "
        "source needs k λ_D/ζ_eq² ≤ 2 (euler, semi-implicit) or ≤ 4/3 (bdf2, extrapolated). Predicted: "
        "the step at which the driver's level ζc (run.json) reaches ζ_eq.", "ζ_eq", "predicted k", source, ".3g")


def glue_section(glue: list[dict]) -> list[str]:
    return measured_bound_section(
        "Tangential glue term",
        "scenes/shear.toml (n = 8/11) with γ_ν = 0 (the glue never debonds), E = 10 in both bodies (the "
        "elastic bound is far away) and the top's displacement held after t = 1, p_τ varied. Predicted: "
        "2/ρ_τ, kρ_τ = λmax(C K⁻¹ Cᵀ W) by power iteration with the scheme's own K (docs/model-choices.md, "
        "\"Explicit glue\"). The paper's scheme only: semi-implicit and bdf2 take the glue implicit, inside the "
        "contact problem (docs/model.md §11(b)), and have no glue bound.", "p_τ", "predicted 2/ρ_τ", glue,
        ".4g")


def normal_glue_section(glue: list[dict]) -> list[str]:
    return measured_bound_section(
        "Normal glue term",
        "The same set-up with p_τ = 0 and no debonding (m_d = 0): the top's lift opens Γ_C and γ_ν β² is a "
        "spring on the opening, γ_ν varied. Predicted: 2/ρ_ν, kρ_ν = λmax(C_ν K⁻¹ C_νᵀ W_ν) with C_ν the "
        "opening's rows and W_ν = γ_ν M_ΓC (docs/model-choices.md, \"Explicit glue\"): the bound of Γ_C open "
        "everywhere. Where the glue sets the step it is sharp, as the tangential one; where the glue is weak against "
        "the bodies, the contact stops the overshoot that would close Γ_C and a run stays bounded above it (the "
        "horizon is at least 50, so that a chatter has the steps to show). The paper's scheme only (semi-implicit "
        "and bdf2 take the glue implicit).", "γ_ν",
        "predicted 2/ρ_ν", glue, ".4g")


# --- benchmark ------------------------------------------------------------------------------

def bench_report(rows: list[dict], solvers: list[dict], models: dict, command: str, fraction: float,
                 fastest: dict, statuses: dict, at_reference: dict, at_check: dict) -> str:
    """The benchmark's README: how each level's N was chosen, the time split, memory and errors of
    every run, the references, every variant's time at the target errors, and the sparse solvers
    on the finest uniform level."""
    measured = [row for row in rows if row["variant"] not in ("reference", "reference check")]
    reference = next(row for row in rows if row["variant"] == "reference")
    check = next(row for row in rows if row["variant"] == "reference check")
    smallest = min(row["errorToReference"] for row in measured)
    resolved = 4 * check["errorToReference"] <= smallest
    degrees = sorted({row["degree"] for row in measured})
    lines = ["# Benchmark: run time against error, the paper's scene", "", *reproduce(command),
             "Every time scheme on uniform and on graded meshes (scenes/paper_graded.toml), bdf2 on meshes adapted "
             "to its error estimate (below), the active-set contact solver, with displacements of degree "
             f"{' and '.join(map(str, degrees))} (*P1*, *P2* in a variant's name: `space.order`"
             + ("; P2 runs one level fewer of each family, two at least, its level ℓ having the nodes of P1's level "
                "ℓ + 1" if degrees == [1, 2] else "") +
             "). *nodes* are the displacement's (at P2 the vertices and the edges' middles). **Steps:** each level's N is chosen so that the scheme's estimated time error is "
             f"{fraction:g} × the level's space error: the time error model of each scheme comes from the pilots of "
             "`time.N = \"auto\"` on uniform level 0 at P1 (below; the time error is the scheme's, used at "
             "both degrees), the space error of a level is bdf2's measured error "
             "there (bdf2 aiming at a quarter of that fraction of the previous level's, whose time error is then "
             "negligible). *time target* and *est. time error* are that aim and the model's estimate at the N "
             "run (N doubled where an explicit bound refused it).", "",
             "Times in seconds: *wall* = meshing (warm cache) + FreeFem++ (start-up, set-up, time loop, output); "
             "set-up, loop and output are FreeFEM's own CPU clock, and start-up is FreeFem++'s wall time less that "
             "clock (negative when multithreaded BLAS puts more CPU than wall time into the factorizations). "
             "With the scenes' CHOLMOD, `solver.condensation = \"auto\"` condenses the contact problem on its "
             "factor: the set-up makes L⁻¹PCᵀ for every contact node, and a step costs one solve per body "
             "in its two halves. *columns*: the part of the loop that made dense columns of K⁻¹Cᵀ instead (only with "
             "`condensation = \"columns\"`: for each group of `solver.columnBlock` nodes along Γ_C when one of "
             "them first became active); *loop* is the rest of the time loop, "
             "its files aside (*output*). *overhead* = loop / N / the back-substitutions a step cannot avoid (one "
             "per body for u, one per body for ζ), timed in the same run, in sets spread over its steps 2 … N; "
             "*after step 1* the same for steps 2 … N, without what the first step does once (bdf2's "
             "semi-implicit start, a fixed point of contact solves; the first active sets): the median, over the "
             "steps followed by sets, of the step's time over a set's, each pair timed in one phase of the "
             "machine (its quartiles in brackets; the run's mean step and mean set, timed at other moments, "
             "drift apart by ±20 % here). K and the damage matrices are factorized in the set-up. "
             "*memory*: FreeFem++'s peak resident memory after set-up and at the end of the run (MB). "
             "*error* = ‖u(T) − u_ref(T)‖_V / ‖u_ref(T)‖_V on the reference's meshes, each run's strains evaluated at their quadrature points; "
             "*error vs check* the same against the check. Runs under 20 s are the fastest of 3 (this machine's "
             "timings drift by ±20 %).", "",
             f"**Reference:** the graded mesh two levels finer than the finest measured at P{reference['degree']}, "
             f"at that degree ({reference['nodes1']} + {reference['nodes2']} nodes), bdf2, N = "
             f"{reference['N']} (time error ≈ 1e-6). **Check:** an independent mesh of the same size — the graded "
             f"level between the finest measured at P{reference['degree']} and the reference's, split once ({check['nodes1']} + {check['nodes2']} nodes), same scheme and N. They lie "
             f"{100 * check['errorToReference']:.3f} % apart; the smallest error reported is {100 * smallest:.3f} %, "
             + ("so the reference is at least four times more accurate than every error in the table."
                if resolved else
                f"so the reference is NOT four times more accurate than the smallest errors: errors below "
                f"{400 * check['errorToReference']:.2f} % are not resolved by it (see *error vs check*)."), ""]
    header = ["variant", "level", "nodes (body 1, 2)", "N", "time target", "est. time error", "wall", "start-up",
              "meshing", "set-up", "columns", "loop", "output", "overhead", "after step 1", "memory set-up / peak",
              "contact it/step", "error", "error vs check"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        cells = [row["variant"], row["level"], f"{row['nodes1']}, {row['nodes2']}", row["N"]]
        cells += [number(row[key]) if key in row else "" for key in ("timeTarget", "estimatedTimeError")]
        cells += [f"{row[key]:.3f}" for key in ("wall", "startup", "meshing", "setup", "columns", "loop", "output")]
        cells += [f"{row['overheadRatio']:.2f}",
                  f"{row['laterOverheadRatio']:.2f} ({row['laterOverheadLow']:.2f}–{row['laterOverheadHigh']:.2f})",
                  f"{row['setupMemoryMB']:.0f} / {row['peakMemoryMB']:.0f}",
                  f"{row['contactIters']:.2f}"]
        for key, own in (("errorToReference", "reference"), ("errorToCheck", "reference check")):
            cells.append(f"{100 * row[key]:.3f} %" if key in row else "–" if row["variant"] == own else "")
        lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    lines += ["", "Time error models (the pilots of orchestrate/steps.py on uniform level 0, n = 6 and 8 "
              "elements per side):", "", "| scheme | N_a | observed order | order used | error at 4N_a |",
              "|---|---|---|---|---|"]
    for scheme, model in models.items():
        lines.append(f"| {scheme} | {model['firstPilot']} | {model['pilots'][-1]['observedOrder']:.2f} | "
                     f"{model['orderUsed']:.2f} | {number(model['finestPilotError'])} |")
    lines += ["", "Wall time to reach an error: the fastest run whose error is at most that (its mesh, N, error "
              "against the reference and the check), and the variant's curve of levels and search runs interpolated "
              "in log–log (against the check in brackets); – where no run reaches it. *search*: how the search "
              "for the coarsest mesh that reaches the error ended, between the two levels that bracket it (the "
              "*search* rows above, each at the N for a time error of the fraction times the target).", "",
              "| variant | error | fastest run reaching it | nodes (body 1, 2) | N | its error (vs check) | "
              "interpolated | search |", "|---|---|---|---|---|---|---|---|"]
    for name, runs in fastest.items():
        for target, run in runs.items():
            interpolated = "–" if at_reference[name][target] is None else f"{at_reference[name][target]:.2f} s"
            interpolated += " (–)" if at_check[name][target] is None else f" ({at_check[name][target]:.2f} s)"
            found = ["–", "", "", ""] if run is None else [
                f"{run['wall']:.3f} s", f"{run['nodes1']}, {run['nodes2']}", run["N"],
                f"{100 * run['errorToReference']:.3f} % ({100 * run['errorToCheck']:.3f} %)"]
            cells = [name, f"{100 * target:g} %", *found, interpolated, statuses[name][target]]
            lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    adapted = [row for row in measured if row["family"] == "adapted"]
    if adapted:
        lines += ["", "Adapted meshes (bdf2): `orchestrate adapt scenes/paper.toml --target E` from the scene's uniform "
                  "pilot (" + "; ".join(dict.fromkeys(f"P{row['degree']}: {row['pilot']}" for row in adapted)) +
                  (": the same nodes" if len(degrees) > 1 else "") + "; no hand-placed singular point), at the N "
                  "of the row; its last run timed as every "
                  "other run (*run*), and the whole loop that designed it (*loop*: the pilot and every cycle's run, "
                  "estimate and meshing); *estimate*: the last design's, NOT REACHED where the loop spent its cycles "
                  "above the target:", "",
                  "| degree | target of the estimate | cycles | estimate | nodes (body 1, 2) | N | error (vs check) | "
                  "run | loop |", "|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| P{row['degree']} | {row['level'].removeprefix('target ')} | {row['adaptCycles']} | {100 * row['adaptEstimate']:.3f} %"
                  f"{'' if row['adaptEstimate'] <= row['adaptTarget'] else ' NOT REACHED'} | "
                  f"{row['nodes1']}, {row['nodes2']} | "
                  f"{row['N']} | {100 * row['errorToReference']:.3f} % ({100 * row['errorToCheck']:.3f} %) | "
                  f"{row['wall']:.3f} s | {row['adaptSeconds']:.2f} s |" for row in adapted]
    lines += ["", "Sparse direct solvers on the P1 matrices of the finest measured uniform level (first solve "
              "includes the factorization):", "",
              "| matrix | dofs | solver | factorization + first solve | next solve |", "|---|---|---|---|---|"]
    for row in solvers:
        lines.append(f"| {row['matrix']} | {row['dofs']} | {row['solver']} | {row['factorSeconds'] * 1000:.1f} ms | "
                     f"{row['solveSeconds'] * 1000:.2f} ms |")
    return "\n".join(lines) + "\n"
