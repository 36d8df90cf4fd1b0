"""facepair's statistics against R's reference implementations on generated data with known
effects: the MOS mixed model against ``lme4::lmer``, the Bradley-Terry-Davidson fit against
BradleyTerry2 (order effect) and psychotools (undecided votes), the mixed BTD model against
``lme4::glmer``. R comes from Debian (:mod:`tests.support.rscript`); without it these tests fail
in CI."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from app.analysis.btd import fit_btd
from app.analysis.mixed_btd import fit_mixed_btd
from app.analysis.ratings import mixed_mos
from tests.support.rscript import run_r

LMER = r"""
suppressMessages(library(lme4))
d <- read.csv("ratings.csv", colClasses = c("character", "character", "character", "numeric"))
d$condition <- factor(d$condition, levels = sort(unique(d$condition)))
m <- lmer(rating ~ 0 + condition + (1 | participant) + (1 | clip), data = d, REML = TRUE,
          control = lmerControl(optCtrl = list(rhoend = 1e-10, maxfun = 1e5)))
vc <- as.data.frame(VarCorr(m))
put(beta = fixef(m), se = sqrt(diag(as.matrix(vcov(m)))),
    sd_participant = vc$sdcor[vc$grp == "participant"], sd_clip = vc$sdcor[vc$grp == "clip"],
    sd_residual = sigma(m), reml = -2 * as.numeric(logLik(m)))
write_out()
"""


def _ratings(seed, P, K, C, sd, keep=1.0, spread=1.0):
    """Every participant rates every clip in every condition (``keep`` < 1: a random share
    of those cells, at least one per participant), 5-point-like ratings from known effects."""
    rng = np.random.default_rng(seed)
    p, k, c = (
        a.ravel() for a in np.meshgrid(np.arange(P), np.arange(K), np.arange(C), indexing="ij")
    )
    mu = np.linspace(2.2, 2.2 + spread, C)
    y = mu[c] + rng.normal(0, sd[0], P)[p] + rng.normal(0, sd[1], K)[k]
    y = y + rng.normal(0, sd[2], len(p))
    chosen = rng.random(len(p)) < keep
    chosen[np.unique(p, return_index=True)[1]] = True
    return pd.DataFrame(
        {
            "participant": [f"P{i:04d}" for i in p[chosen]],
            "clip": [f"clip{i:02d}" for i in k[chosen]],
            "condition": [f"c{i}" for i in c[chosen]],
            "rating": np.round(y[chosen], 3),
        }
    )


@pytest.mark.parametrize(
    "case",
    [
        # balanced: 40 participants x 6 clips x 3 conditions
        dict(seed=11, P=40, K=6, C=3, sd=(0.6, 0.3, 0.7)),
        # unbalanced: a random 35 % of the cells, participants with 1 to 20 ratings
        dict(seed=12, P=60, K=8, C=4, sd=(0.5, 0.4, 0.8), keep=0.35),
        # clips that barely differ: the clip variance near (or on) its boundary
        dict(seed=13, P=50, K=5, C=2, sd=(0.7, 0.0, 0.6)),
        # 0-100 slider scale, large variances
        dict(seed=14, P=30, K=10, C=5, sd=(12.0, 6.0, 15.0), spread=40.0),
    ],
    ids=["balanced", "unbalanced", "boundary", "slider"],
)
def test_mos_model_equals_lmer(case, tmp_path):
    data = _ratings(**case)
    data.to_csv(tmp_path / "ratings.csv", index=False)
    ref = run_r(LMER, tmp_path, packages=("lme4",))
    ours = mixed_mos(data)
    conditions = ours["conditions"]
    beta = [ours["mos"][c] for c in conditions]
    assert beta == pytest.approx(ref["beta"], abs=1e-4)
    z = 1.959963984540054
    se = [(ours["ci"][c][1] - ours["ci"][c][0]) / (2 * z) for c in conditions]
    assert se == pytest.approx(ref["se"], abs=1e-4)
    assert ours["sd_residual"] == pytest.approx(ref["sd_residual"][0], abs=1e-4)
    assert ours["sd_participant"] == pytest.approx(ref["sd_participant"][0], abs=1e-4)
    assert ours["sd_clip"] == pytest.approx(ref["sd_clip"][0], abs=1e-4)


BTM = r"""
suppressMessages(library(BradleyTerry2))
d <- read.csv("pairs.csv")
lev <- paste0("c", 0:(max(c(d$left, d$right))))
p1 <- data.frame(item = factor(lev[d$left + 1], levels = lev), at.home = 1)
p2 <- data.frame(item = factor(lev[d$right + 1], levels = lev), at.home = 0)
m <- BTm(cbind(d$wins_left, d$wins_right), p1, p2, formula = ~ item + at.home, id = "item",
         control = glm.control(epsilon = 1e-14, maxit = 100))
cf <- coef(m)
put(theta = c(0, cf[grepl("^item", names(cf))]), log_g = cf[["at.home"]])
write_out()
"""


@pytest.mark.parametrize("seed", [21, 22])
def test_btd_order_effect_equals_bradleyterry2(seed, tmp_path):
    # decided votes only, every ordered pair shown: Bradley-Terry with an order effect
    rng = np.random.default_rng(seed)
    n = 5
    theta, g = np.array([0.0, 0.4, 0.9, -0.3, 0.2]), 1.6
    counts = np.zeros((n, n, 3))
    rows = []
    for i in range(n):
        for j in range(n):
            if i != j:
                m = int(rng.integers(10, 40))
                left = rng.binomial(
                    m, g * np.exp(theta[i]) / (g * np.exp(theta[i]) + np.exp(theta[j]))
                )
                counts[i, j] = [left, m - left, 0]
                rows.append((i, j, left, m - left))
    pd.DataFrame(rows, columns=["left", "right", "wins_left", "wins_right"]).to_csv(
        tmp_path / "pairs.csv", index=False
    )
    ref = run_r(BTM, tmp_path, packages=("BradleyTerry2",))
    fit = fit_btd(counts)
    assert fit.converged and fit.nu == 0.0
    assert (fit.theta - fit.theta[0]).tolist() == pytest.approx(ref["theta"], abs=1e-6)
    assert np.log(fit.gamma) == pytest.approx(ref["log_g"][0], abs=1e-6)


BTMODEL = r"""
suppressMessages(library(psychotools))
d <- read.csv("pairs.csv")  # first < second (0-based); value 1 first, -1 second, 0 undecided
nobj <- max(c(d$first, d$second)) + 1
ix <- which(upper.tri(diag(nobj)), arr.ind = TRUE)  # psychotools' order of the pairs
M <- matrix(NA_integer_, nrow(d), nrow(ix))
for (r in seq_len(nrow(d))) {
  M[r, which(ix[, 1] == d$first[r] + 1 & ix[, 2] == d$second[r] + 1)] <- d$value[r]
}
y <- paircomp(M, labels = paste0("c", 0:(nobj - 1)), mscale = c(-1, 0, 1))
m <- btmodel(y, weights = d$w, type = "loglin", ref = 1, undecided = TRUE,
             epsilon = 1e-14, maxit = 100)
cf <- coef(m)
put(theta = c(0, cf[names(cf) != "(undecided)"]), log_nu = cf[["(undecided)"]],
    loglik = as.numeric(logLik(m)))
write_out()
"""


@pytest.mark.parametrize("seed", [31, 32])
def test_btd_undecided_equals_psychotools(seed, tmp_path):
    # Davidson's ties: psychotools' log-linear model with an undecided parameter (it has no
    # position effect, so facepair's fit holds g at 1)
    rng = np.random.default_rng(seed)
    n = 4
    theta, nu = np.array([0.0, 0.4, 0.9, -0.3]), 0.7
    counts = np.zeros((n, n, 3))
    rows = []
    for i in range(n):
        for j in range(i + 1, n):
            pi, pj = np.exp(theta[i]), np.exp(theta[j])
            tie = nu * np.sqrt(pi * pj)
            x = rng.multinomial(
                int(rng.integers(20, 60)), np.array([pi, pj, tie]) / (pi + pj + tie)
            )
            a = rng.binomial(x, 0.5)  # the sides each pair was shown on
            counts[i, j] = a
            counts[j, i] = [x[1] - a[1], x[0] - a[0], x[2] - a[2]]
            rows += [(i, j, v, w) for v, w in zip((1, -1, 0), x, strict=True)]
    pd.DataFrame(rows, columns=["first", "second", "value", "w"]).to_csv(
        tmp_path / "pairs.csv", index=False
    )
    ref = run_r(BTMODEL, tmp_path, packages=("psychotools",))
    fit = fit_btd(counts, side=False)
    assert fit.converged and fit.gamma == 1.0
    assert (fit.theta - fit.theta[0]).tolist() == pytest.approx(ref["theta"], abs=1e-6)
    assert np.log(fit.nu) == pytest.approx(ref["log_nu"][0], abs=1e-6)
    assert fit.loglik == pytest.approx(ref["loglik"][0], abs=1e-6)


GLMER = r"""
suppressMessages(library(lme4)); suppressMessages(library(Matrix))
d <- read.csv("votes.csv")  # participant p, clip k, left i, right j (0-based), y = left chosen
n <- max(c(d$i, d$j)) + 1; P <- max(d$p) + 1; K <- max(d$k) + 1; N <- nrow(d)
X <- matrix(0, N, n); X[cbind(1:N, d$i + 1)] <- 1; X[cbind(1:N, d$j + 1)] <- -1
for (q in 2:n) d[[paste0("x", q)]] <- X[, q]
# b_pi and c_ki enter as +1 for the left condition and -1 for the right: lme4's modular
# interface with the random-effects design Zt replaced (a multi-membership design)
d$pc <- factor(rep(0:(P * n - 1), length.out = N), levels = 0:(P * n - 1))
d$kc <- factor(rep(0:(K * n - 1), length.out = N), levels = 0:(K * n - 1))
fml <- as.formula(paste("y ~ 1 +", paste0("x", 2:n, collapse = " + "), "+ (1 | pc) + (1 | kc)"))
gf <- glFormula(fml, data = d, family = binomial)
block <- function(g, m) sparseMatrix(i = c(g * n + d$i, g * n + d$j) + 1, j = c(1:N, 1:N),
                                     x = c(rep(1, N), rep(-1, N)), dims = c(m, N))
blocks <- list(pc = block(d$p, P * n), kc = block(d$k, K * n))
gf$reTrms$Zt <- as(do.call(rbind, blocks[names(gf$reTrms$cnms)]), "CsparseMatrix")
devf <- do.call(mkGlmerDevfun, gf)
opt <- optimizeGlmer(devf)
devf <- updateGlmerDevfun(devf, gf$reTrms)
opt <- optimizeGlmer(devf, stage = 2)
m <- mkMerMod(environment(devf), opt, gf$reTrms, fr = gf$fr)
vc <- as.data.frame(VarCorr(m))
cf <- fixef(m)
put(theta = c(0, cf[-1]), log_g = cf[[1]], sd_participant = vc$sdcor[vc$grp == "pc"],
    sd_clip = vc$sdcor[vc$grp == "kc"])
write_out()
"""


@pytest.mark.parametrize("seed", [41, 42, 43])
def test_mixed_btd_within_its_tolerance_of_glmer(seed, tmp_path):
    # decided votes, 80 participants x 8 clips x the 3 pairs of 3 conditions, sides at random;
    # participant x condition sd 0.6, clip x condition sd 0.4. Penalised quasi-likelihood
    # shrinks a binary model's effects and variances against the Laplace fit (Breslow & Lin
    # 1995): on these designs the score differences, the side effect and the participant SD
    # come out 5-8 % smaller than glmer's, the clip SD within 0.03 (docs/reference/analysis.md)
    rng = np.random.default_rng(seed)
    P, K, n = 80, 8, 3
    theta, lam = np.array([0.0, 0.5, 1.0]), 0.3
    b, c = rng.normal(0, 0.6, (P, n)), rng.normal(0, 0.4, (K, n))
    t = np.zeros((P, K, n, n, 3))
    rows = []
    for p in range(P):
        for k in range(K):
            for first, second in ((0, 1), (0, 2), (1, 2)):
                i, j = (first, second) if rng.random() < 0.5 else (second, first)
                eta = lam + theta[i] - theta[j] + b[p, i] - b[p, j] + c[k, i] - c[k, j]
                y = int(rng.random() < 1.0 / (1.0 + np.exp(-eta)))
                t[p, k, i, j, 0 if y else 1] += 1
                rows.append((p, k, i, j, y))
    pd.DataFrame(rows, columns=["p", "k", "i", "j", "y"]).to_csv(
        tmp_path / "votes.csv", index=False
    )
    ref = run_r(GLMER, tmp_path, packages=("lme4",))
    fit = fit_mixed_btd(t)
    assert fit.converged
    ours = fit.theta - fit.theta[0]
    ratio = ours[1:] / np.array(ref["theta"][1:])
    assert np.all((ratio > 0.90) & (ratio < 1.0)), ratio
    assert 0.90 < np.log(fit.gamma) / ref["log_g"][0] < 1.0
    assert 0.90 < fit.sd_participant / ref["sd_participant"][0] < 1.0
    assert fit.sd_clip == pytest.approx(ref["sd_clip"][0], abs=0.03)
