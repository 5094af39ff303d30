"""Tolerance propagation: the pure estimators against closed forms and brute force, the config
section's refusals, the robust objective of the GA and one small end-to-end study."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from whisker_opt.optimise import robust as rb

H = np.array([0.2, 0.3, 0.1, 0.2, 10.0, 0.1])  # the default half-widths
A = np.array([1.5, -0.8, 2.0, 0.5, 0.01, -3.0])  # slopes of the test functions


def linear(x):
    return [2.0 + A @ x]


def near_linear(x):
    """Linear plus a small curvature: (b/2) Σ (x_j/h_j)² with b = 0.01 (the curvature the expansion ignores)."""
    return [2.0 + A @ x + 0.005 * np.sum((x / H) ** 2), 1.0 - 0.5 * (A @ x)]


# ----------------------------------------------------------------------------- the sample
@pytest.mark.parametrize("distribution, sigma", [("uniform", H / math.sqrt(3.0)), ("normal", H / 3.0)])
@pytest.mark.parametrize("sampling", ["lhs", "monte_carlo"])
def test_sample_of_a_linear_function_has_the_closed_form_std(distribution, sigma, sampling):
    # f = c + a·x with independent x_j: std = sqrt(Σ a_j² σ_j²) exactly, mean = c
    n = 4000
    est = rb.sample_estimate(linear, rb.draw(n, H, distribution, sampling, seed=3))
    exact_std = math.sqrt(np.sum((A * sigma) ** 2))
    tol = 0.01 if sampling == "lhs" else 0.04  # LHS: stratified, error O(1/n); MC: O(1/sqrt(n)), 4000 points: ~1.1 % (3.5 sd)
    assert est.std[0] == pytest.approx(exact_std, rel=tol)
    assert abs(est.mean[0] - 2.0) < 4 * exact_std / math.sqrt(n)
    # the sample's linear fit recovers the slopes of a linear function to round-off
    np.testing.assert_allclose(est.slopes[0], A, rtol=1e-9, atol=1e-12)


def test_latin_hypercube_hits_every_stratum_once_and_uniform_stays_in_the_band():
    n = 50
    x = rb.draw(n, H, "uniform", "lhs", seed=11)
    assert x.shape == (n, H.size)
    assert np.all(np.abs(x) <= H)
    u = (x / H + 1.0) / 2.0  # back to the unit cube
    strata = np.sort(np.floor(u * n).astype(int), axis=0)
    np.testing.assert_array_equal(strata, np.tile(np.arange(n)[:, None], (1, H.size)))


def test_the_same_seed_gives_the_same_sample():
    for sampling in ("lhs", "monte_carlo"):
        a = rb.draw(20, H, "normal", sampling, seed=7)
        np.testing.assert_array_equal(a, rb.draw(20, H, "normal", sampling, seed=7))
        assert not np.array_equal(a, rb.draw(20, H, "normal", sampling, seed=8))


def test_zero_tolerance_gives_a_zero_column_and_costs_no_difference():
    h = H.copy()
    h[2] = 0.0
    assert np.all(rb.draw(10, h, seed=1)[:, 2] == 0.0)
    calls = []

    def f(x):
        calls.append(np.array(x))
        return linear(x)

    est = rb.expansion_estimate(f, h, corners=False)
    assert est.n_evaluations == len(calls) == 1 + 2 * 5
    assert est.gradient[0, 2] == 0.0


@pytest.mark.parametrize("bad, word", [((0.1, -1.0), "half_widths"), ((0.1, math.nan), "half_widths")])
def test_bad_half_widths_are_refused(bad, word):
    with pytest.raises(ValueError, match=word):
        rb.draw(5, bad)


# ----------------------------------------------------------------------------- the expansion
@pytest.mark.parametrize("distribution", ["uniform", "normal"])
def test_expansion_matches_a_brute_force_sample_for_a_near_linear_function(distribution):
    """Mean and std of the first-order expansion (2n+1 = 13 evaluations) against 20 000 Monte Carlo points.

    The curvature term moves the true mean by (b/2) Σ σ_j²/h_j² (0.005·6/3 = 0.01 uniform) and
    adds ~0.2 % to the std; the Monte Carlo error of 20 000 points is 0.7 % of the std for the
    mean and 0.5 % for the std. Stated tolerance: std within 2 %, mean within 0.02 (the std is
    0.32: 6 % of it, twice the curvature's shift plus 3 Monte Carlo standard errors).
    """
    exp = rb.expansion_estimate(near_linear, H, distribution, worse=(1, -1))
    brute = rb.sample_estimate(near_linear, rb.draw(20_000, H, distribution, "monte_carlo", seed=5), worse=(1, -1))
    assert exp.n_evaluations == 13 + 1  # 2n+1, plus one corner shared by both outputs (they worsen together)
    assert exp.std[0] == pytest.approx(brute.std[0], rel=0.02)
    assert exp.std[1] == pytest.approx(brute.std[1], rel=0.02)
    assert abs(exp.mean[0] - brute.mean[0]) < 0.02
    assert abs(exp.mean[1] - brute.mean[1]) < 0.02
    # the central difference of a quadratic is exact: gradient = A
    np.testing.assert_allclose(exp.gradient[0], A, rtol=1e-9)


def test_expansion_worst_corner_follows_the_gradient_signs():
    exp = rb.expansion_estimate(near_linear, H, worse=(1, -1))
    np.testing.assert_array_equal(exp.corners[0], np.sign(A) * H)  # larger is worse
    np.testing.assert_array_equal(exp.corners[1], np.sign(A) * H)  # -0.5·A: smaller is worse -> the same corner
    assert exp.worst[0] == pytest.approx(near_linear(np.sign(A) * H)[0], rel=1e-12)
    # no point of a brute-force sample beats the corner of a monotone function
    brute = rb.sample_estimate(near_linear, rb.draw(2000, H, seed=2), worse=(1, -1))
    assert brute.worst[0] <= exp.worst[0]
    assert brute.worst[1] >= exp.worst[1]


def test_robust_objective_is_mean_plus_k_std():
    assert rb.robust_objective(1.0, 0.25, 2.0) == pytest.approx(1.5)
    np.testing.assert_allclose(rb.robust_objective([1.0, 2.0], [0.1, 0.2], 0.0), [1.0, 2.0])


# ----------------------------------------------------------------------------- the config section
def test_default_tolerances_are_those_stated():
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.config.robustness import TOLERANCE_KEYS

    cfg = WhiskerConfig()
    assert dict(zip(TOLERANCE_KEYS, cfg.robustness.tolerances.half_widths())) == {
        "alpha": 0.2, "l": 0.3, "t": 0.1, "fibre_radius": 0.2, "C10": 10.0, "calibration": 0.1}
    assert cfg.optimiser is None or cfg.optimiser.robust is None


@pytest.mark.parametrize("key, value", [("alpha", -0.1), ("t", 5.0), ("C10", 100.0), ("fibre_radius", ".nan")])
def test_a_bad_tolerance_is_one_line_naming_the_key(tmp_path, key, value):
    from whisker_opt.config.model import ConfigError, load_config

    path = tmp_path / "r.yaml"
    path.write_text(f"robustness:\n  tolerances:\n    {key}: {value}\n")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    msg = str(err.value)
    assert "\n" not in msg
    assert f"robustness.tolerances.{key}" in msg
    assert "allowed range" in msg or "finite" in msg


def test_the_command_refuses_a_bad_tolerance_in_one_line(tmp_path, capsys):
    from whisker_opt.cli import main as cli

    path = tmp_path / "r.yaml"
    path.write_text("scene: {Q_i: 0.2}\n")
    for setting, words in (("robustness.tolerances.l=-1", "robustness.tolerances.l: -1"),
                           ("robustness.tolerances.calibration=1.5", "robustness.tolerances.calibration: 1.5")):
        extra = ["--set", "scene.calibration=1"] if "calibration" in setting else []
        rc = cli.main(["robustness", str(path), "--set", setting, *extra, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1, err
        assert err[0].startswith("whisker-opt robustness: error: ") and words in err[0], err
    assert not (tmp_path / "o").exists()  # refused before anything was written


def test_a_sample_too_small_for_the_sensitivities_is_refused_in_one_line(tmp_path, capsys):
    """Six non-zero tolerances need 7 points for the linear fit's slopes; fewer gave NaN sensitivities."""
    from whisker_opt import robustness as study
    from whisker_opt.cli import main as cli
    from whisker_opt.config.model import WhiskerConfig

    path = tmp_path / "r.yaml"
    path.write_text("scene: {Q_i: 0.2}\n")
    for args in (["--samples", "6"], ["--method", "both", "--set", "robustness.sample.n=3"]):
        rc = cli.main(["robustness", str(path), *args, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1, err
        assert err[0].startswith("whisker-opt robustness: error: robustness.sample.n (--samples): ") and \
            "the minimum is 7" in err[0], err
    assert not (tmp_path / "o").exists()  # refused before anything was written
    # zero tolerances need no slope: two live ones need 3 points; the expansion needs no sample
    cfg = WhiskerConfig.model_validate({"robustness": {"sample": {"n": 3}, "tolerances": {
        "alpha": 0, "l": 0, "t": 0, "fibre_radius": 0, "C10": 10, "calibration": 0.1}}})
    study.check_sample_size(cfg, ["sample"])
    study.check_sample_size(cfg.model_copy(update={"robustness": cfg.robustness.model_copy(
        update={"sample": cfg.robustness.sample.model_copy(update={"n": 2})})}), ["expansion"])
    with pytest.raises(study.RobustnessError, match=r"robustness.sample.n \(--samples\): 2 is too few .* minimum is 3"):
        study.check_sample_size(cfg.model_copy(update={"robustness": cfg.robustness.model_copy(
            update={"sample": cfg.robustness.sample.model_copy(update={"n": 2})})}), ["both"])
    # the linear fit itself: d + 1 points give finite slopes, d points none
    x = rb.draw(7, [1.0] * 6, seed=1)
    assert np.all(np.isfinite(rb.linear_fit_slopes(x, x @ np.arange(6.0)[:, None])))
    assert np.all(np.isnan(rb.linear_fit_slopes(x[:6], x[:6] @ np.arange(6.0)[:, None])))


# ----------------------------------------------------------------------------- the robust objective
@dataclass(frozen=True)
class _Analytic:
    """A stand-in for SceneEvaluator: f1 linear in the genes, the fibre fraction and C10 (no FE)."""

    base_spec: object
    trim: float = 5.0

    def __call__(self, genes):
        from whisker_opt.experiment.outcome import EvalOutcome

        d = self.base_spec.design
        f1 = (1e-3 + 2e-3 * genes["alpha"] - 1e-3 * genes["l"] + 4e-3 * genes["t"] + 3e-3 * d.fibre_radius_frac
              + 0.02 * self.base_spec.c10)
        return EvalOutcome.success(f1 * self.base_spec.calibration / 3.9, {"total": 0.0}, {"delta_l": 1.0})


def _robust(method: str, k: float, n: int = 16):
    from whisker_opt import wiring
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.optimise.aggregate import AggregateEvaluator, FabricationVariants

    cfg = WhiskerConfig.model_validate({"optimiser": {"robust": {"k": k, "method": method}},
                                        "robustness": {"sample": {"n": n, "seed": 4}}, "fidelity": {"preset": "coarse"}})
    real = wiring.evaluator(cfg)
    assert isinstance(real, AggregateEvaluator) and isinstance(real.variants, FabricationVariants)
    assert (real.reduction, real.label, real.k) == ("mean_plus_k_std", "robust", k)
    assert real.samples().shape == (500,)  # the wrapped evaluator's, as finish_best reads them
    return cfg, replace(real, nominal=_Analytic(real.base_spec))


def _sample_f1(ev, genes):
    """f1 of the stand-in at each point of the sample, each design deviated independently here."""
    values = []
    for x in ev.variants.points:
        dev = dict(zip(("alpha", "l", "t", "fibre_radius", "C10", "calibration"), x))
        g = {**genes, "alpha": genes["alpha"] + dev["alpha"], "l": genes["l"] + dev["l"], "t": genes["t"] + dev["t"]}
        spec = ev.base_spec
        d = replace(spec.design, fibre_radius_frac=spec.design.fibre_radius_frac + dev["fibre_radius"] / genes["t"])
        spec = replace(spec, design=d, c10=spec.c10 * (1 + dev["C10"] / 100),
                       calibration=spec.calibration + dev["calibration"])
        values.append(_Analytic(spec)(g).f1)
    return np.array(values)


def test_robust_objective_of_the_expansion_is_the_closed_form():
    cfg, ev = _robust("expansion", 1.5)
    genes = {"alpha": 4.0, "l": 11.0, "t": 2.6, "Q_i": 0.2}
    out = ev(genes)
    f0 = _Analytic(ev.base_spec)(genes).f1
    sigma = np.asarray(cfg.robustness.tolerances.half_widths()) / math.sqrt(3.0)  # uniform: h/√3
    c10 = ev.base_spec.c10
    # d f1 / d deviation, in the deviation's unit: genes direct, fibre mm -> frac / t, C10 % -> C10/100, ξ: f1/ξ
    slopes = np.array([2e-3, -1e-3, 4e-3, 3e-3 / 2.6, 0.02 * c10 / 100.0, f0 / ev.base_spec.calibration])
    std = math.sqrt(np.sum((slopes * sigma) ** 2))
    assert out.ok and out.f1 == f0  # f1 is the nominal design's
    assert out.measures["f1_std"] == pytest.approx(std, rel=1e-9)
    assert out.measures["f1_mean"] == f0  # the expansion's mean is f(x0)
    assert out.measures["f1_robust"] == pytest.approx(f0 + 1.5 * std, rel=1e-9)
    assert out.measures["delta_l_robust"] == 1.0  # every measure is aggregated: Δl is 1 at every variant
    assert out.reason.startswith("f1_robust = mean_plus_k_std of f1") and f"f1 (nominal) = {f0:.6g}" in out.reason
    assert out.extra["variant_evaluations"] == 11  # nominal + 2 per parameter but ξ, which needs no solve


def test_robust_objective_of_the_sample_is_mean_plus_k_std_of_the_wrapped_function():
    _, ev = _robust("sample", 2.0, n=12)
    genes = {"alpha": 3.0, "l": 12.0, "t": 3.0, "Q_i": 0.1}
    values = _sample_f1(ev, genes)
    out = ev(genes)
    assert len(values) == 12
    assert out.f1 == _Analytic(ev.base_spec)(genes).f1
    assert out.measures["f1_robust"] == pytest.approx(np.mean(values) + 2.0 * np.std(values, ddof=1), rel=1e-9)
    assert out.measures["f1_mean"] == pytest.approx(np.mean(values), rel=1e-9)
    np.testing.assert_allclose(out.extra["variant_f1"], values, rtol=1e-12)


def test_the_robust_evaluator_pickles_for_the_process_executors():
    import pickle

    _, ev = _robust("sample", 1.0, n=4)
    back = pickle.loads(pickle.dumps(ev))
    genes = {"alpha": 3.5, "l": 12.0, "t": 3.0, "Q_i": 0.1}
    assert back == ev
    np.testing.assert_equal(back(genes).measures, ev(genes).measures)  # NaN where the stand-in has no reading


def test_a_ga_run_records_the_nominal_f1_and_the_robust_objective_beside_it(tmp_path):
    from whisker_opt.optimise.penalty import dynamic_penalty, penalty_terms
    from whisker_opt.optimise.runner import run_optimisation
    from whisker_opt.report import report
    from whisker_opt.output.storage import read_csv

    cfg, ev = _robust("sample", 1.0, n=6)
    opt = cfg.optimiser.model_copy(update={"ga": cfg.optimiser.ga.model_copy(update={"population": 4, "n_elite": 1}),
                                           "stopping": cfg.optimiser.stopping.model_copy(update={"max_generations": 1})})
    run_optimisation(opt, tmp_path / "run", ev, seed=1, progress=False)
    rows = [r for r in read_csv(tmp_path / "run" / "evaluations.csv") if r["status"] == "ok"]
    assert rows and "f1_nominal" not in rows[0]
    for r in rows:  # f1 is the nominal design's; f1_robust, the GA's objective, is mean + k·std of the variants' f1
        genes = {k: float(r[k]) for k in ("alpha", "l", "t", "Q_i")}
        values = _sample_f1(ev, genes)
        assert float(r["f1"]) == _Analytic(ev.base_spec)(genes).f1
        assert float(r["f1_robust"]) == pytest.approx(np.mean(values) + 1.0 * np.std(values, ddof=1), rel=1e-9)
        assert float(r["f1_mean"]) == pytest.approx(np.mean(values), rel=1e-9)
        assert float(r["f1_std"]) == pytest.approx(np.std(values, ddof=1), rel=1e-9)
        assert float(r["F_p"]) == pytest.approx(dynamic_penalty(float(r["f1_robust"]), genes, penalty_terms(opt))[1],
                                                rel=1e-12)
    best = json.loads((tmp_path / "run" / "best.json").read_text())
    assert best["objective"] == "f1_robust"
    first = best["best_designs"][0]
    assert list(first)[list(first).index("f1") + 1] == "f1_robust"
    assert best["f1_robust"] == first["f1_robust"] and best["f1"] == first["f1"]
    gens = read_csv(tmp_path / "run" / "generations.csv")
    assert float(gens[-1]["best_f1_robust"]) == best["f1_robust"] and float(gens[-1]["best_f1"]) == best["f1"]
    text = report(tmp_path / "run")
    assert f"  f1_robust  {best['f1_robust']:.6g} calibrated  (minimised; f1 is the nominal design's)" in text


def test_without_the_robust_option_the_evaluator_is_the_plain_one():
    from whisker_opt import wiring
    from whisker_opt.config.model import WhiskerConfig
    from whisker_opt.optimise.evaluator import SceneEvaluator

    cfg = WhiskerConfig.model_validate({"optimiser": {"trim": 5.0}})
    assert type(wiring.evaluator(cfg)) is SceneEvaluator
    robust_cfg = WhiskerConfig.model_validate({"optimiser": {"trim": 5.0, "robust": {}}})
    assert wiring.evaluator(robust_cfg, robust=False) == wiring.evaluator(cfg)


def test_the_studied_designs_follow_the_configs_genome(tmp_path, capsys):
    """An added gene of ``optimiser.genes`` is a gene of every studied design: the config's own value of its key,
    or the value after Q_i of a ``--genes`` genome; a genome of another length is refused in one line."""
    from whisker_opt import robustness as study
    from whisker_opt import wiring
    from whisker_opt.cli import main as cli
    from whisker_opt.config.model import load_config

    text = "design: {fibre_pitch: 2.5}\nscene: {Q_i: 0.2}\noptimiser: {trim: 5.0, genes: {fibre_pitch: [2, 4]}}\n"
    path = tmp_path / "g.yaml"
    path.write_text(text)
    cfg = load_config(path)
    (own,) = study.config_designs(cfg)
    assert own.genes == {"alpha": 2.862, "l": 15.0, "t": 3.0, "Q_i": 0.2, "fibre_pitch": 2.5}
    (given,) = study.config_designs(cfg, [(3.0, 12.0, 2.5, 0.1, 2.2)])
    assert given.genes == {"alpha": 3.0, "l": 12.0, "t": 2.5, "Q_i": 0.1, "fibre_pitch": 2.2}
    assert {s.design.fibre_pitch for s in wiring.design_scene_specs(cfg, given.genes).values()} == {2.2}
    with pytest.raises(study.RobustnessError, match=r"genome 1: 4 values given, .* has 5 \(alpha, l, t, Q_i, "
                                                    r"fibre_pitch, in that order\)"):
        study.config_designs(cfg, [(3.0, 12.0, 2.5, 0.1)])
    rc = cli.main(["robustness", str(path), "--genes", "3,12,2.5,0.1", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "4 values given" in err[0], err
    assert not (tmp_path / "o").exists()


# ----------------------------------------------------------------------------- end to end
def test_robustness_command_end_to_end_at_coarse(tmp_path, capsys):
    """The calibration tolerance alone: one FE design (3 scenes) and closed forms, since every
    reading is proportional to ξ: std(f1) = f1·σ_ξ/ξ, worst f1 = f1·(ξ + h)/ξ, recovery unchanged."""
    from whisker_opt.cli import main as cli
    from whisker_opt.experiment.objective import f1 as f1_of

    cfg = tmp_path / "c.yaml"
    cfg.write_text("fidelity: {preset: coarse}\nscene: {Q_i: 0.2}\noptimiser: {trim: 5.0}\n"
                   "robustness:\n  tolerances: {alpha: 0, l: 0, t: 0, fibre_radius: 0, C10: 0, calibration: 0.3}\n")
    out = tmp_path / "out"
    assert cli.main(["robustness", str(cfg), "--method", "expansion", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "expansion" in printed and "recovery rate" in printed
    rows = list(csv.DictReader((out / "robustness.csv").open()))
    assert len(rows) == 1 and rows[0]["method"] == "expansion" and rows[0]["solves"] == "1"
    from whisker_opt.config.model import load_config

    recorded = load_config(out / "config.yaml")  # the --out folder records the resolved config it ran
    assert recorded.robustness.tolerances.calibration == 0.3 and recorded.fidelity.preset == "coarse"
    r = {k: float(v) for k, v in rows[0].items() if k not in ("design", "method", "f1_run")}
    xi = 3.9
    assert r["f1_std"] == pytest.approx(r["f1_nominal"] * 0.3 / math.sqrt(3.0) / xi, rel=1e-9)
    assert r["f1_worst"] == pytest.approx(r["f1_nominal"] * (xi + 0.3) / xi, rel=1e-9)
    assert r["recovery_rate_std"] == pytest.approx(0.0, abs=1e-9)
    data = json.loads((out / "robustness.json").read_text())
    assert data["designs"][0]["methods"]["expansion"]["worst_corner"]["f1"]["calibration"] == 0.3
    # the nominal f1 is the GA's f1 of the same genome (the same scenes, solved independently)
    from whisker_opt import workflows
    from whisker_opt.config.model import load_config

    c = load_config(cfg)
    genes = {"alpha": c.design.alpha, "l": c.design.l, "t": c.design.t, "Q_i": 0.2}
    ref = workflows.evaluate(c, genes, keep_curves=True)
    assert r["f1_nominal"] == pytest.approx(ref.f1, rel=1e-9)
    assert ref.f1 == pytest.approx(f1_of(np.array(ref.extra["eps_i"]), np.array(ref.extra["eps_c"])), rel=1e-12)
    assert (out / "robustness.png").stat().st_size > 10_000
