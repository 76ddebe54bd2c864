"""The textbook's printed results found wrong, as data; ``references/ERRATA.md`` is generated
from it (``python -m harness.references.errata`` rewrites the file; ``tests/references/test_errata.py`` fails when
the file and this module disagree, or when a named test does not exist).

Every entry names the test that shows it. A printed result is listed here only after the
corrected formula was derived again and verified by a tight independent integration (SciPy
DOP853 at rtol 1e-12); OCR damage and typos that do not change a result are listed separately.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

BOOK = "Boström, *Rigid body dynamics* (OCR'd copy `shared/textbook/rigid-body-dynamics.txt` beside the repository)"
ERRATA_PATH = Path(__file__).resolve().parent / "ERRATA.md"


@dataclass(frozen=True)
class Erratum:
    """One wrong printed result.

    Attributes:
        location: example or section, with the text line of the OCR'd copy.
        title: what is wrong, in a few words.
        kind: ``wrong result``, ``wrong remark``, ``incomplete remark``, ``sign error`` or
            ``dimensional error``.
        printed: what the book prints.
        correct: the verified statement.
        why: the derivation or the cause, briefly.
        tests: ``path::test_name`` of the tests that show it.
    """

    location: str
    title: str
    kind: str
    printed: str
    correct: str
    why: str
    tests: tuple[str, ...]


ERRATA: tuple[Erratum, ...] = (
    Erratum(
        location="§4.7, after Eq. 4.69 (l. 2355)",
        title="direction of the precession of ω about the symmetry axis",
        kind="incomplete remark",
        printed="\"If I_3 > I_1 then ω rotates in the positive direction around the z axis\"",
        correct="ω rotates at the rate γ ω_3, γ = (I_3 − I_1)/I_1: positive only when ω_3 > 0 as well; "
                "for ω_3 < 0 it rotates the other way.",
        why="The rate is γ ω_3 (Eqs. 4.66–4.69), which changes sign with ω_3.",
        tests=("tests/references/test_torque_free.py::test_symmetric_precession_rate_textbook",),
    ),
    Erratum(
        location="§4.7, after Eq. 4.73 (l. 2370)",
        title="which cone rolls inside which for a flat body",
        kind="wrong remark",
        printed="\"I_1 < I_3 (a flat body) then α_3 < α_b and the body cone rolls inside the space cone\"",
        correct="For a flat body L lies between the symmetry axis and ω, α_s = α_b − α_3 < α_b: the space cone "
                "lies inside the body cone, and the body cone rolls around it. (The slender-body statement, "
                "external contact with α_3 = α_b + α_s, is right.)",
        why="tan α_3 = (I_1/I_3) tan α_b from Eqs. 4.70 and 4.72, so α_3 < α_b when I_1 < I_3.",
        tests=("tests/references/test_torque_free.py::test_torque_free_cone_geometry",),
    ),
    Erratum(
        location="Ex. 4.7.1 (l. 2372–2412)",
        title="normal force on a rolling cone's base rim",
        kind="wrong result",
        printed="I_x'x' = (3/10) m L² (axial moment about the apex) and N = (3/4) m g cos²β − (m v²/(L cos β)) "
                "[3 cos³β/(10 sin β) + sin β cos β (3/5 + (3/20) tan²β)], \"for sufficiently great Ω the normal force "
                "becomes negative\" (the cone lifts off)",
        correct="I_x'x' = (3/10) m L² tan²β (= 3 m R²/10) and N = (3/4) m g cos²β + (m v² sin β / L)(9/10 + (3/20) tan²β): "
                "the normal force grows with the speed and never becomes negative",
        why="Two errors. The axial moment of a solid cone about its apex is 3 m R²/10 with R = L tan β, which turns the "
            "bracket's first term 3 cos³β/(10 sin β) into (3/10) sin β cos β. And the moment equation about the apex, "
            "(3/4) m g L cos β − N L/cos β = −m L² Ω² [...], gives N = (3/4) m g cos²β + m L Ω² cos β [...]: the "
            "printed minus is a sign slip in the last step. Three routes agree to 1e-13 (closed form, moment equation, "
            "numerical dL_O/dt along the exact rotation); runs of scene rolling_cone (m = 1 kg, L = 0.2 m, β = 0.3) hold "
            "N = 7.052716 N at v = 0.5 m/s (printed 5.329882 N) in-house and in Pinocchio to 1e-14 of m g, Exudyn "
            "7.052717 N, MuJoCo's soft contact 7.045885 N; at v = 1.5 m/s the printed value is −5.75 N (lift-off) where "
            "the runs hold 9.754815 N on the rim.",
        tests=("tests/references/test_rolling_cone.py::test_printed_normal_force_is_wrong_and_the_cone_never_lifts_off",
               "tests/references/test_rolling_cone.py::test_apex_moments_by_quadrature"),
    ),
    Erratum(
        location="Ex. 4.7.2 (l. 2447, 2458)",
        title="speed of a disk rolling on a circle: v printed for v², lever arm r for R",
        kind="dimensional error",
        printed="v = 4 g r² cos β / ((6r + R cos β) sin β); moment line (F_n r sin β − N r cos β) e_y'",
        correct="v² = 4 g r² cos β / ((6r + R cos β) sin β) (thin uniform disk, r the radius of the centre's "
                "circle); the moment of the contact force about the centre is (F_n R sin β − N R cos β) e_y'. "
                "For a disk of half-thickness h on its rim edge: w3 = [φ̇²((A + mh²) sθ cθ + mRh sθ²) − mg(R cθ − "
                "h sθ)] / (φ̇((C + mR²) sθ + mRh cθ)) (harness.references.rolling_disk.steady_spin).",
        why="The right-hand side has the dimension m²/s². The contact point is at distance R from the centre, "
            "so its lever arm is R; the printed final formula follows from R, only the intermediate line has r. "
            "The closed form keeps the lean constant to 1e-8 rad in a maximal-coordinate Newton-Euler "
            "integration (and to 1e-11 rad in the in-house and Pinocchio runs of scene rolling_disk).",
        tests=("tests/references/test_rolling_disk.py::test_ex_472_printed_formula_is_the_speed_squared",
               "tests/references/test_rolling_disk.py::test_steady_circular_motion_keeps_the_lean"),
    ),
    Erratum(
        location="Ex. 5.1.1 (l. 2627)",
        title="generalized force of the piston force on a crankshaft",
        kind="sign error",
        printed="Q_θ = F dx/dθ = −F a sin θ (1 − a cos θ/√(b² − a² sin² θ))",
        correct="Q_θ = F dx/dθ = −F a sin θ (1 + a cos θ/√(b² − a² sin² θ)) (with an offset e of the piston's "
                "line: Q_θ = F(−a sin θ + a s cos θ/w), s = e − a sin θ, w = √(b² − s²); "
                "harness.references.slider_crank.generalized_force_piston)",
        why="The book's own lines before it are right: x = a cos θ + √(b² − a² sin² θ) and δx = −(a sin θ + "
            "a² sin θ cos θ/√(b² − a² sin² θ)) δθ; factoring −a sin θ out of δx gives (1 + …). The printed form "
            "differs from F dx/dθ by 2F a² sin θ cos θ/√(…): for a = 0.1 m, b = 0.3 m, F = −2 N at θ = 0.5 rad it "
            "gives 0.0675 N m instead of 0.1243 N m. With it the crank's equation of motion does not conserve "
            "T + V − F x (drift > 1e-3 relative in 2 s; the corrected Q_θ: < 1e-11), and the corrected one "
            "agrees with a constrained integration in (θ, φ, x) and with the in-house engine (scene "
            "slider_crank).",
        tests=("tests/references/test_slider_crank.py::test_ex_511_printed_generalized_force_has_the_wrong_sign",
               "tests/references/test_slider_crank.py::test_reference_matches_the_multiplier_form"),
    ),
    Erratum(
        location="Ex. 5.2.2 (l. 2854)",
        title="nonlinear φ equation of the double pendulum",
        kind="sign error",
        printed="mL²[(1/3)φ̈ + ½θ̈ cos(φ−θ) − ½θ̇² sin(φ−θ)] + ½mgL sin φ = 0",
        correct="mL²[(1/3)φ̈ + ½θ̈ cos(φ−θ) + ½θ̇² sin(φ−θ)] + ½mgL sin φ = 0",
        why="d/dt ∂T/∂φ̇ contains −½mL²θ̇(φ̇−θ̇) sin(φ−θ) and ∂T/∂φ = −½mL²θ̇φ̇ sin(φ−θ); together "
            "+½mL²θ̇² sin(φ−θ). With the printed sign the energy drifts by more than 1e-2 relative; with "
            "the corrected sign by less than 1e-10. (The OCR line carries a stray ')'; either way the printed "
            "sign is not physical.)",
        tests=("tests/references/test_double_pendulum.py::test_double_pendulum_ex522_printed_sign_breaks_energy",),
    ),
    Erratum(
        location="Ex. 5.2.3 (l. 2856–2905)",
        title="equations of motion of the rolling disk from a Lagrangian with the rolling constraint substituted",
        kind="wrong result",
        printed="φ̈(1 + 5cos²θ) − 10φ̇θ̇ cos θ sin θ + 6ψ̈ cos θ − 6θ̇ψ̇ sin θ = 0,  ψ̈ + φ̈ cos θ − φ̇θ̇ sin θ = 0 "
                "(and ∂T/∂φ̇, ∂T/∂ψ̇ conserved)",
        correct="A(φ̈ sin θ + 2φ̇θ̇ cos θ) = C w3 θ̇ and (C + mR²) ẇ3 = mR² φ̇θ̇ sin θ, w3 = ψ̇ + φ̇ cos θ "
                "(A = mR²/4, C = mR²/2; the θ equation printed is right).",
        why="The rolling constraint is nonholonomic: substituting it into T and then applying Lagrange's "
            "equations to φ, θ, ψ as free coordinates is not allowed (Ex. 5.2.1 itself says so). Newton-Euler "
            "with the contact force as unknown gives the correct equations; the printed spin equation keeps w3 "
            "constant while the true w3 changes.",
        tests=("tests/references/test_rolling_disk.py::test_ex_523_printed_equations_disagree_with_newton_euler",
               "tests/references/test_rolling_disk.py::test_euler_angle_equations_match_newton_euler"),
    ),
    Erratum(
        location="Ex. 5.3.3 (l. 3020–3042)",
        title="critical speed of a disk rolling straight",
        kind="wrong result",
        printed="φ̈ − (6v/R) ξ̇ = 0; stable for v > √(gR)/3 (0.12 m/s for R = 14 mm)",
        correct="φ̈ = (2v/R) ξ̇; stable for v > √(gR/3) (0.214 m/s for R = 14 mm). With half-thickness h, on "
                "one rim edge at the balance tilt atan(h/R): Ω² > m g l D/(C (C + mR²)(C + m l²)), l = √(R² + h²), "
                "D = AC + AmR² + Cmh², v = RΩ (0.2153 m/s for R = 14 mm, h = 1 mm).",
        why="The linearised heading equation comes from the wrong Ex. 5.2.3 (C/A = 2, not 6). The printed "
            "threshold is what the printed equations give; the correct dynamics contradict it: a thin disk at "
            "0.17 m/s falls. In scene rolling_disk all four engines (in-house, Pinocchio, Exudyn, MuJoCo) fall at "
            "0.15–0.21 m/s and roll on at 0.22 m/s and above (`harness rolling-study`, reports/rolling_disk.md).",
        tests=("tests/references/test_rolling_disk.py::test_printed_threshold_follows_from_the_printed_equations_and_the_dynamics_contradict_it",
               "tests/references/test_rolling_disk.py::test_critical_speed_is_the_linearisation_of_the_correct_equations"),
    ),
    Erratum(
        location="Ex. 5.3.1 (l. 2974)",
        title="energy exchange of the spring pendulum at equal frequencies",
        kind="wrong remark",
        printed="\"If it should happen that the two frequencies become equal, ω_1 = ω_2, then the two "
                "oscillations couple ... energy is gradually transferred between the two types of oscillation.\"",
        correct="ω_1 = ω_2 requires a zero-length spring (L = 0), for which the motion is exactly linear and "
                "uncoupled in Cartesian coordinates: no energy is ever transferred. The internal resonance at "
                "which energy moves between the spring and the swing is ω_1 = 2ω_2.",
        why="k/m = g/r* with r* = L + mg/k gives L = 0; then V = mgz + ½k(x² + z²) and T = ½m(ẋ² + ż²). At "
            "ω_1 = 2ω_2 the quadratic terms mrθ̇² and ½mgrθ² drive the radial motion at 2ω_2 and modulate the "
            "pendulum length at 2ω_2 (autoparametric resonance). From the same start (r* + 0.05 m, 0.02 rad, "
            "r* = 0.245 m) the swing's share of the energy rises from 0.2 % to 99.99 % within 4 s at 2:1; at "
            "1:1 it stays below 2.3 % (geometric mixing of polar and Cartesian modes only), at 3:1 below 0.25 %. "
            "The three engines reproduce the 2:1 exchange (scene spring_pendulum).",
        tests=("tests/references/test_spring_pendulum.py::test_textbook_equal_frequencies_is_linear_no_exchange",
               "tests/references/test_spring_pendulum.py::test_two_to_one_resonance_exchanges_energy"),
    ),
    Erratum(
        location="Ex. 5.3.2 (l. 2997)",
        title="right-hand side of the linearised double-pendulum equations",
        kind="dimensional error",
        printed="(4/3)θ̈ + ½φ̈ + (3g/2L)θ = F_0 L cos ωt",
        correct="(4/3)θ̈ + ½φ̈ + (3g/2L)θ = F_0 cos(ωt)/(mL)   (or, undivided, mL²[…] = F_0 L cos ωt)",
        why="The left-hand side has been divided by mL², the right-hand side has not. Ex. 6.2.1 then uses the "
            "undivided M and Q consistently, so its result is unaffected.",
        tests=("tests/references/test_double_pendulum.py::test_double_pendulum_linear_response_exact",
               "tests/references/test_double_pendulum.py::test_double_pendulum_nonlinear_small_amplitude"),
    ),
    Erratum(
        location="Ex. 6.2.1 (l. 3329)",
        title="modal mass m_1 of the double pendulum",
        kind="wrong result",
        printed="m_1 = 1.12 mL²",
        correct="m_1 = u_1ᵀ M u_1 = 1.13118 mL² (m_2 = 0.13 mL² is right)",
        why="1.12 is what the two-digit rounded mode vector (0.57, 0.82) gives (1.1247): the rounding error of "
            "Ex. 6.1.1 was carried into a printed result, about 1 % off.",
        tests=("tests/references/test_double_pendulum.py::test_double_pendulum_textbook_ex611_ex621_numbers",),
    ),
    Erratum(
        location="Problem 5.12 (answer l. 3515)",
        title="the φ equation of the semicylinder on a smooth plane",
        kind="wrong result",
        printed="(4/(3π)) ẍ cos φ + R φ̈ + (4/(3π)) g sin φ = 0",
        correct="(8/(3π)) ẍ cos φ + R φ̈ + (8/(3π)) g sin φ = 0, i.e. m c ẍ cos φ + (m R²/2) φ̈ + m g c sin φ = 0 "
                "with c = 4R/(3π) (the x equation, ẍ + c φ̈ cos φ − c φ̇² sin φ = 0, is right)",
        why="Lagrange in φ gives m c ẍ cos φ + I_O φ̈ + m g c sin φ = 0 with I_O = m R²/2, the semicylinder's moment "
            "about its axis (the same as the whole cylinder's); the printed coefficients hold for I_O = m R². "
            "Small oscillations: ω² = g c/(R²/2 − c²) = 1.327 g/R, the printed equations give g c/(R² − c²) = "
            "0.518 g/R (a period 1.60 times too long). The engines agree with the corrected equations (scene "
            "rocking_semicylinder, phi0 = 0.5 rad, 3 s): in-house, MuJoCo and Pinocchio to 1.6e-9 rad, Drake to "
            "1.5e-8, Exudyn (order 2) to 1.5e-4; the printed ones are 0.99 rad away. (A lost "
            "factor ½ in front of R φ̈ would also explain it; as printed, the equation is wrong.)",
        tests=("tests/references/test_rocking_semicylinder.py::test_problem_512_printed_phi_equation_is_wrong",),
    ),
)

# OCR damage and typos that do not change a printed result.
MINOR: tuple[tuple[str, str], ...] = (
    ("Ex. 5.2.2", "the intermediate line of T reads mL²[θ̇² + ¼φ̇² + θ̇φ̇ cos(φ−θ)], without the factor ½; "
                  "the final T is right."),
    ("Eq. 6.26", "printed (ω_i² − ω_i²), should read (ω_j² − ω_i²) (OCR)."),
    ("Ex. 5.2.3", "∂T/∂θ is printed as ¼mR²(5φ̇² cos θ sin θ − 6φ̇ψ̇ sin θ); it is −¼mR²(5φ̇² cos θ sin θ + "
                  "6φ̇ψ̇ sin θ); the θ equation that follows is right. Its gravity term reads 4(4g/R) cos θ (OCR "
                  "of 4(g/R) cos θ)."),
    ("Ex. 5.3.3", "refers to the equations 'derived in Example 5.2.2' (they are in Ex. 5.2.3); the linearised θ "
                  "equation lacks ξ in its last term, −(4g/R)ξ (OCR)."),
    ("Ex. 1.6.1", "the pendulum's velocity at the vertical is written Ẋ − Lθ̇ with θ̇ taken as a speed; with the "
                  "angle of Ex. 1.2.2 it is Ẋ + Lθ̇ (θ̇ < 0 on the way down from θ = π/2). A sign convention: "
                  "the printed cart speed is right."),
)

# Printed results checked and found correct, with the test that checks them.
VERIFIED: tuple[tuple[str, str, str], ...] = (
    ("Ex. 1.2.2, 1.3.1", "cart pendulum: kinematics and equations of motion",
     "tests/references/test_cart_pendulum.py::test_textbook_ex161_cart_speed_and_ex151_frequency"),
    ("Ex. 1.5.1", "ω = √((M + m)g/(ML))",
     "tests/references/test_cart_pendulum.py::test_textbook_ex161_cart_speed_and_ex151_frequency"),
    ("Ex. 1.6.1", "Ẋ = √(2m²gL/(M(M + m)))",
     "tests/references/test_cart_pendulum.py::test_textbook_ex161_cart_speed_and_ex151_frequency"),
    ("Ex. 2.2.1", "angular velocity of a top in the non-spinning frame",
     "tests/references/test_heavy_top.py::test_heavy_top_cos_theta_matches_integration"),
    ("Problem 3.4 (answer l. 3445)", "collars: v_B = (1/3)v e_y, a_B = −25v²/(27L) e_y (guides skew at OD = 0.3L, "
     "b = OA = 0.4L; the figure is not in the OCR'd copy)",
     "tests/references/test_slider_crank.py::test_problem_34_collars"),
    ("Ex. 4.2.1, 4.5.1", "plate inertia m(a² + b²)/3 and (4/3)m(a² + b²) about the corner",
     "tests/references/test_plate_pendulum.py::test_textbook_plate_inertia"),
    ("Ex. 4.5.1", "ω_max = √(3g(√(a² + b²) − b)/(2(a² + b²)))",
     "tests/references/test_plate_pendulum.py::test_textbook_ex451_ex452_largest_angular_velocity_and_support_force"),
    ("Ex. 4.5.2", "F_n = mg + 3mg(√(a² + b²) − b)/(2√(a² + b²)), F_s = 0",
     "tests/references/test_plate_pendulum.py::test_textbook_ex451_ex452_largest_angular_velocity_and_support_force"),
    ("Ex. 4.6.1", "plate on a skew axis: L, dL/dt = −(1/3)ma²ω² cos φ sin φ e_y, F = ma²ω² cos φ sin φ/(6d)",
     "tests/references/test_rotating_plate.py::test_couple_is_the_rate_of_angular_momentum"),
    ("§4.7, Eqs. 4.60–4.73", "Euler's equations, stability β, symmetric solution, cone angles",
     "tests/references/test_torque_free.py::test_torque_free_textbook_stability_beta"),
    ("Ex. 5.1.1", "sin φ = (a/b) sin θ, x = a cos θ + √(b² − a² sin² θ), δx (the Q_θ that follows: erratum)",
     "tests/references/test_slider_crank.py::test_ex_511_printed_generalized_force_has_the_wrong_sign"),
    ("Problem 5.12 (answer l. 3515)", "the x equation ẍ + (4/(3π)) R φ̈ cos φ − (4/(3π)) R φ̇² sin φ = 0 (the φ "
     "equation: erratum)",
     "tests/references/test_rocking_semicylinder.py::test_lagrange_equations_against_newton_euler"),
    ("Ex. 3.4.1 (l. 1704)", "rolling cone: ω = v/(L sin β) along the contact generator, Ω = v/(L cos β), spin "
     "−(Ω/sin β) along the axis",
     "tests/references/test_rolling_cone.py::test_initial_state_rolls_without_slip"),
    ("Problem 5.13 (answer l. 3519)", "rolling cylinder (4m, R) with a pinned bar (m, 4R) released horizontal: "
     "θ̇ = √(21g/(25R)) at the vertical",
     "tests/references/test_rolling_cylinder_bar.py::test_textbook_release_reaches_the_printed_rate"),
    ("Ex. 5.3.1", "Lagrange's equations, r* = L + mg/k, ω_1 = √(k/m), ω_2 = √(g/r*)",
     "tests/references/test_spring_pendulum.py::test_textbook_frequencies_from_small_oscillations"),
    ("Ex. 6.1.1", "ω = 0.86, 2.30 √(g/L); mode ratios 1.43, −2.10; unit vectors",
     "tests/references/test_double_pendulum.py::test_double_pendulum_textbook_ex611_ex621_numbers"),
    ("Ex. 6.2.1", "Y_k = L F_0 u_1^k (cos ωt − cos ω_k t)/(m_k(ω_k² − ω²)); m_2 = 0.13 mL²",
     "tests/references/test_double_pendulum.py::test_double_pendulum_ex621_formula"),
)


def render() -> str:
    """The text of ``references/ERRATA.md``."""
    lines = [
        "# Errata of the textbook",
        "",
        "<!-- Generated by `python -m harness.references.errata` from references/errata.py; do not edit by hand. -->",
        "",
        f"Printed results of {BOOK} found wrong. Each was derived again and the correction verified",
        "by a tight independent integration (SciPy DOP853, rtol 1e-12) in the test named with it.",
        "",
        "| # | where | what | kind | test |",
        "|---|---|---|---|---|",
    ]
    for i, e in enumerate(ERRATA, 1):
        tests = "<br>".join(f"`{t.split('::')[1]}`" for t in e.tests)
        lines.append(f"| {i} | {e.location} | {e.title} | {e.kind} | {tests} |")
    lines.append("")
    for i, e in enumerate(ERRATA, 1):
        lines += [
            f"## {i}. {e.location}: {e.title} ({e.kind})",
            "",
            f"* **Printed:** {e.printed}",
            f"* **Correct:** {e.correct}",
            f"* **Why:** {e.why}",
            "* **Shown by:** " + ", ".join(f"`{t}`" for t in e.tests),
            "",
        ]
    lines += ["## OCR damage and typos (no printed result affected)", ""]
    lines += [f"* **{where}:** {what}" for where, what in MINOR]
    lines += ["", "## Printed results checked and found correct", "", "| where | result | test |", "|---|---|---|"]
    lines += [f"| {where} | {what} | `{test}` |" for where, what, test in VERIFIED]
    lines.append("")
    return "\n".join(lines)


def main() -> None:  # pragma: no cover - a maintenance command
    ERRATA_PATH.write_text(render())
    print(f"wrote {ERRATA_PATH}")


if __name__ == "__main__":  # pragma: no cover
    main()
