"""The likelihood of the mixed Bradley-Terry-Davidson model (:mod:`app.analysis.mixed_btd`)
and the Newton solve of its penalised quasi-likelihood, in blocks.

For given variances of the participant and clip effects, :meth:`MixedBTDModel.mode` finds
the joint mode of fixed and random effects (Breslow & Clayton 1993, JASA 88, 9-25, sec. 2)
and :func:`app.analysis.mixed_btd_variances.schall_update` is Schall's (1991) REML update
from it; the fit that alternates them, with its acceleration and stopping rule, is
:func:`app.analysis.mixed_btd.fit_mixed_btd`.

A vote's likelihood depends on its two worths through their difference alone, so the sums of
the vote cells into participants, clips and (participant, clip) blocks are products with
signed incidence matrices made once; the Hessian is block-diagonal in the participants'
effects, and every solve goes through the Schur complement of that block, so the cost is
linear in the cells that hold votes and in participants.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse

from app.analysis.mixed_btd_cells import Cells, incidences, sparse_product_into

MIN_VARIANCE = 1e-8  # a random effect taken as absent
#: Vote cells :meth:`MixedBTDModel._per_cell` takes at a time (its temporaries, 256 KB each,
#: stay in the core's cache).
CHUNK = 1 << 15


class MixedBTDModel:
    """Dense effects z = (theta, lambda[, kappa], c) and participant effects b (P, n), with the
    vote counts ``t`` (P, K, n, n, 3), same-condition pairs set to 0."""

    def __init__(self, t: np.ndarray) -> None:
        self.P, self.K, self.n = t.shape[:3]
        self.ties = bool(t[..., 2].sum() > 0)
        self.use_p, self.use_c = self.P > 1, self.K > 1
        self.nf = self.n + 1 + int(self.ties)  # fixed effects
        self.m = self.nf + (self.K * self.n if self.use_c else 0)
        # the cells that hold votes, (participant, clip, left, right): a design shows each
        # participant a few pairs per clip, so most of the (P, K, n, n) cells are empty
        n, K = self.n, self.K
        width, offset = (self.m, self.nf) if self.use_c else (K * n, 0)
        # indices in 32 bits where they fit: half the memory to fault in and to stream
        index = np.int32 if max(t.size, self.P * n * width) < 2**31 else np.int64
        by_cell = t.reshape(-1, 3)
        total = by_cell[:, 0] + by_cell[:, 1] + by_cell[:, 2]
        at_cell = np.flatnonzero(total).astype(index)  # ((p K + k) n + i) n + j, in order
        self.y = by_cell[at_cell].astype(np.float64)  # (N, 3)
        self.total = total[at_cell].astype(np.float64)
        del total
        cells = len(at_cell)
        pk, cj = np.divmod(at_cell, n)
        pk, ci = np.divmod(pk, n)  # pk = p K + k
        cp, ck = np.divmod(pk, K)
        # the cells' worths in the flattened (P, K, n) worths
        pk *= n
        self.at_wi, self.at_wj = pk + ci, pk + cj
        del pk, at_cell

        # A vote's log-likelihood depends on its worths through a_i - a_j alone: the sums of
        # the cells into participants, clips and (participant, clip) blocks are products
        # with signed incidence matrices made once (:func:`incidences`)
        self.to_p, self.to_k, self.to_block = incidences(
            Cells(cp, ck, ci, cj), (self.P, K, n), width, offset, index
        )
        self.sums = {"y_l": float(self.y[:, 0].sum()), "y_t": float(self.y[:, 2].sum())}
        chunk = min(cells, CHUNK)
        self.work = {
            key: np.empty(chunk) for key in ("delta", "pl", "pt", "d", "pr", "tpl", "tpt", "spare")
        }
        self.work["hess"] = np.empty(cells)
        self.work["per_cell"] = np.empty((cells, 3 if self.ties else 2))
        self.work["worth"] = np.empty((self.P, K, n))
        self.y_half = self.y[:, 0] + self.y[:, 2] / 2.0  # a left vote counts 1, undecided 1/2

    def _per_cell(
        self, z: np.ndarray, b: np.ndarray
    ) -> tuple[float, np.ndarray, np.ndarray, dict[str, float]]:
        """The log-likelihood and, per cell, in delta = a_i - a_j: the gradient, minus the
        cross derivatives with lambda (and kappa) as columns of one (N, 2 or 3) array, minus
        the second derivative, and the sums the fixed effects need (w_xy: minus the Hessian
        in the outcomes' logits, summed over the cells).

        Each cell relative to its right-hand outcome: the outcomes' odds are exp(lambda +
        delta) (left), exp(kappa + delta / 2) (undecided) and 1 (the right's worth cancels
        from the log-likelihood, the counts of a cell adding up to its total). The arrays over
        the cells are the model's own, rewritten in place at every call: this is the fit's
        inner loop, and arrays made anew each time cost as much again in page faults.
        """
        n, K, nf, w = self.n, self.K, self.nf, self.work
        lam = float(z[n])
        kap = float(z[n + 1]) if self.ties else 0.0
        worth = w["worth"]  # (P, K, n): theta + b_p + c_k
        if self.use_c:
            np.add(b[:, None, :], z[nf:].reshape(K, n)[None, :, :], out=worth)
        else:
            worth[:] = b[:, None, :]
        worth += z[:n]
        flat = worth.reshape(-1)
        per_cell, hess = w["per_cell"], w["hess"]
        # the sums of the log-likelihood and of the fixed effects' curvature (w_xy), in
        # order: y_l delta, y_t delta, total log D, tpl, tpl pl, tpt, tpl pt, tpt pt
        acc = np.zeros(8)
        for start in range(0, len(self.total), CHUNK):
            part = slice(start, min(start + CHUNK, len(self.total)))
            self._chunk(flat, part, lam, kap, acc)
        sums = {"tpl": float(acc[3]), "w_ll": float(acc[3] - acc[4])}
        ll = float(acc[0]) + lam * self.sums["y_l"] - float(acc[2])
        if self.ties:
            ll += float(acc[1]) / 2.0 + kap * self.sums["y_t"]
            sums.update(tpt=float(acc[5]), w_lt=-float(acc[6]), w_tt=float(acc[5] - acc[7]))
        return ll, per_cell, hess, sums

    def _chunk(
        self, flat: np.ndarray, part: slice, lam: float, kap: float, acc: np.ndarray
    ) -> None:
        """:meth:`_per_cell` for the cells ``part``: its columns of the per-cell arrays, its
        terms added to ``acc``. A chunk's temporaries stay in the core's cache, where the
        whole arrays (a few megabytes each) went out to memory at every step."""
        w = self.work
        size = part.stop - part.start
        delta, pl, pt, d, pr, tpl, tpt, spare = (
            w[k][:size] for k in ("delta", "pl", "pt", "d", "pr", "tpl", "tpt", "spare")
        )
        per_cell, hess = w["per_cell"][part], w["hess"][part]
        np.take(flat, self.at_wi[part], out=delta)
        delta -= np.take(flat, self.at_wj[part], out=spare)
        # (exponents held within +-600: far beyond any estimable effect, short of overflow)
        np.add(delta, lam, out=pl)
        np.clip(pl, -600.0, 600.0, out=pl)
        np.exp(pl, out=pl)
        np.add(pl, 1.0, out=d)
        if self.ties:
            np.multiply(delta, 0.5, out=pt)
            pt += kap
            np.clip(pt, -600.0, 600.0, out=pt)
            np.exp(pt, out=pt)
            d += pt
        np.reciprocal(d, out=pr)
        pl *= pr  # P(left)
        np.log(d, out=d)
        y_l, y_t, total = self.y[part, 0], self.y[part, 2], self.total[part]
        acc[0] += y_l @ delta
        acc[2] += total @ d
        np.multiply(total, pl, out=tpl)
        g, with_l = per_cell[:, 0], per_cell[:, 1]
        np.subtract(self.y_half[part], tpl, out=g)
        np.multiply(tpl, pr, out=hess)  # w_ll + w_lt + w_tt / 4, without ties
        with_l[:] = hess  # w_ll + w_lt / 2, without ties
        acc[3] += tpl.sum()
        acc[4] += tpl @ pl
        if self.ties:
            pt *= pr  # P(undecided)
            acc[1] += y_t @ delta
            np.multiply(total, pt, out=tpt)
            np.multiply(tpt, 0.5, out=spare)
            g -= spare
            np.subtract(1.0, pt, out=spare)
            spare *= tpt
            spare *= 0.25
            hess += spare
            np.multiply(tpl, pt, out=spare)
            spare *= 0.5
            with_l += spare
            np.subtract(pr, pl, out=spare)
            spare *= tpt
            np.multiply(spare, 0.5, out=per_cell[:, 2])  # w_lt + w_tt / 2
            acc[5] += tpt.sum()
            acc[6] += tpl @ pt
            acc[7] += tpt @ pt

    def terms(self, z: np.ndarray, b: np.ndarray, slot: int | None = None) -> dict[str, Any]:
        """Log-likelihood, its gradient and minus its Hessian in blocks: dense-dense C,
        participant blocks A (P, n, n) and participant-dense B (P, n, m).

        ``slot`` (0 or 1): the large arrays go into the model's own pair of that number,
        rewritten at the next call with the same slot (the fit alternates the two, so the
        terms of the point it stands on survive those of a trial step); None: new arrays.

        Every vote's worths are a = theta + b_p + c_k, so the derivatives are taken in the
        (participant, clip) worths of the cells that hold votes and summed into participants,
        clips or both (sparse products over the cells: the cost is linear in those cells, not
        in P K n^2). Local variables of a vote (i left, j right): delta = a_i - a_j, lambda,
        kappa; minus the Hessian of its log-likelihood in them is J' W J with W = N (diag(pi) -
        pi pi') and J the outcomes' coefficients (left 1, 1, 0; undecided 1/2, 0, 1; right 0).
        """
        P, K, n, m, nf = self.P, self.K, self.n, self.m, self.nf
        ll, per_cell, hess, sums = self._per_cell(z, b)
        by_p = self._product(self.to_p, per_cell, slot, "by_p")  # (P n, 2 or 3)
        by_k = self.to_k @ per_cell  # (K n, 2 or 3)
        # the (participant, clip) n x n blocks of minus the Hessian in the worths, in B
        placed = self._product(self.to_block, hess, slot, "placed")
        if self.use_c:
            bb = placed.reshape(P, n, m)
            blocks = bb[:, :, nf:].reshape(P, n, K, n)
        else:
            bb, blocks = np.empty((P, n, m)), placed.reshape(P, n, K, n)
        g_p, h_al_p = by_p[:, 0].reshape(P, n), by_p[:, 1].reshape(P, n)
        aa = np.einsum(  # (P, n, n); 5x faster than .sum(axis=2)
            "pikj->pij", blocks, out=None if slot is None else self._array(f"aa{slot}", (P, n, n))
        )
        per_clip = blocks.sum(axis=0).transpose(1, 0, 2)  # (K, n, n)
        gz, gb = np.zeros(m), np.zeros((P, n))
        cc = np.zeros((m, m))
        gz[:n] = g_p.sum(axis=0)
        gz[n] = self.sums["y_l"] - sums["tpl"]
        cc[:n, :n] = aa.sum(axis=0)
        cc[:n, n] = h_al_p.sum(axis=0)
        cc[n, n] = sums["w_ll"]
        if self.ties:
            h_ak_p = by_p[:, 2].reshape(P, n)
            gz[n + 1] = self.sums["y_t"] - sums["tpt"]
            cc[:n, n + 1] = h_ak_p.sum(axis=0)
            cc[n, n + 1] = sums["w_lt"]
            cc[n + 1, n + 1] = sums["w_tt"]
        if self.use_c:
            gz[nf:] = by_k[:, 0]
            for k in range(K):
                block = slice(nf + k * n, nf + (k + 1) * n)
                cc[block, block] = per_clip[k]
                cc[:n, block] = per_clip[k]
            cc[n, nf:] = by_k[:, 1]
            if self.ties:
                cc[n + 1, nf:] = by_k[:, 2]
        if self.use_p:
            gb = g_p
            bb[:, :, :n] = aa
            bb[:, :, n] = h_al_p
            if self.ties:
                bb[:, :, n + 1] = h_ak_p
        else:
            bb[:] = 0.0
            aa = np.zeros((P, n, n))
        upper = np.triu(cc, 1)
        cc = np.triu(cc) + upper.T  # filled above the diagonal only
        return {"ll": ll, "gz": gz, "gb": gb, "C": cc, "A": aa, "B": bb, "slot": slot}

    def _array(self, key: str, shape: tuple[int, ...]) -> np.ndarray:
        """The model's own array ``key`` (made at the first call)."""
        if key not in self.work:
            self.work[key] = np.empty(shape)
        return self.work[key]

    def _product(
        self, matrix: sparse.csc_array, x: np.ndarray, slot: int | None, name: str
    ) -> np.ndarray:
        """``matrix @ x``, into the model's array ``name`` of ``slot`` when one is given."""
        if slot is None:
            return np.asarray(matrix @ x)
        out = self._array(f"{name}{slot}", (matrix.shape[0], *x.shape[1:]))
        return sparse_product_into(matrix, x, out)

    def penalised(self, z: np.ndarray, b: np.ndarray, var: np.ndarray, ll: float) -> float:
        """F: minus the log-likelihood plus the random effects' Gaussian penalty (and the
        (sum theta)^2 / 2 that fixes theta's mean without moving the maximum)."""
        f = -ll + 0.5 * float(np.square(z[: self.n].sum()))
        if self.use_p:
            f += 0.5 * float((b**2).sum()) / var[0]
        if self.use_c:
            f += 0.5 * float((z[self.nf :] ** 2).sum()) / var[1]
        return f

    def active(self, var: np.ndarray) -> tuple[bool, bool]:
        """Which random effects are in the model: present in the design, variance not 0."""
        return self.use_p and var[0] > MIN_VARIANCE, self.use_c and var[1] > MIN_VARIANCE

    def solve(self, z: np.ndarray, b: np.ndarray, var: np.ndarray, t: dict[str, Any]) -> Solve:
        """The Newton step of F (H^-1 times its gradient) through the Schur complement of the
        participant blocks, with the pieces of H^-1 the variance update needs. An absent
        effect (variance 0) is held at 0: its step returns it there."""
        n, m, nf = self.n, self.m, self.nf
        use_p, use_c = self.active(var)
        gz = -t["gz"]
        gz[:n] += z[:n].sum()
        s = t["C"].copy()
        s[:n, :n] += 1.0
        if use_c:
            gz[nf:] += z[nf:] / var[1]
            s[nf:, nf:] += np.eye(m - nf) / var[1]
        elif m > nf:
            s[nf:, :], s[:, nf:] = 0.0, 0.0
            s[nf:, nf:] = np.eye(m - nf)
            gz[nf:] = z[nf:]
        if not use_p:
            s_inv = np.linalg.inv(s)
            return Solve(s_inv @ gz, b.copy(), s_inv, None, None)
        bb = t["B"]
        if not use_c and m > nf:  # the clip effects held at 0: no coupling to them
            bb = bb.copy()
            bb[:, :, nf:] = 0.0
        gb = -t["gb"] + b / var[0]
        a_inv = np.linalg.inv(t["A"] + np.eye(n) / var[0])
        # A^-1 B, (P, n, m), in the model's own array: a fresh one at every solve was 15 MB
        # more to fault in (10,000 participants), which cost more than the product
        if "x" not in self.work:
            self.work["x"] = np.empty_like(bb)
        x = np.matmul(a_inv, bb, out=self.work["x"])
        # sums over participants and their conditions as one matrix product (tensordot's
        # transposes copied the (P, n, m) blocks: 17 ms against 2 ms at 1,000 participants)
        flat_b = bb.reshape(-1, m)
        s -= flat_b.T @ x.reshape(-1, m)
        s_inv = np.linalg.inv(s)
        a_inv_g = np.matmul(a_inv, gb[:, :, None])[:, :, 0]
        dz = s_inv @ (gz - flat_b.T @ a_inv_g.reshape(-1))
        return Solve(dz, a_inv_g - x @ dz, s_inv, a_inv, x)

    def mode(
        self,
        var: np.ndarray,
        z: np.ndarray,
        b: np.ndarray,
        t: dict[str, Any] | None = None,
        *,
        tol: float = 1e-7,
        max_iter: int = 50,
        one_step: bool = False,
    ) -> tuple[np.ndarray, np.ndarray, Solve, bool, dict[str, Any]]:
        """The joint mode of fixed and random effects for the given variances (Newton steps
        with step halving from ``z``, ``b``; ``t`` their :meth:`terms` if known, which do not
        depend on the variances), the solve there and its terms.

        ``one_step``: take one Newton step only and return its end with the solve at its start
        (the working-variate iteration of PQL, Breslow & Clayton 1993 sec. 2: one step of the
        effects per variance update). At the fixed point of the variance updates the step is 0
        and the solve is the mode's; on the way, each update costs one pass over the votes and
        one solve instead of two passes and three solves."""
        t = self.terms(z, b, slot=0) if t is None else t
        f = self.penalised(z, b, var, t["ll"])
        for _ in range(max_iter):
            try:
                step = self.solve(z, b, var, t)
            except np.linalg.LinAlgError:
                break
            if not one_step and _largest(step) < tol:  # at the mode already: its solve is here
                return z, b, step, True, t
            scale = 1.0
            for _half in range(30):
                z_new, b_new = z - scale * step.dz, b - scale * step.db
                t_new = self.terms(z_new, b_new, slot=_other_slot(t))
                f_new = self.penalised(z_new, b_new, var, t_new["ll"])
                if f_new <= f + 1e-10 * max(1.0, abs(f)):
                    break
                scale /= 2.0
            else:  # no step decreases F beyond rounding: this is the mode
                return z, b, step, True, t
            if one_step:
                return z_new, b_new, step, True, t_new
            z, b, t, f = z_new, b_new, t_new, f_new
            moved = max(np.abs(scale * step.dz).max(), np.abs(scale * step.db).max(initial=0.0))
            if moved < tol:
                try:
                    return z, b, self.solve(z, b, var, t), True, t
                except np.linalg.LinAlgError:  # a flat direction at the mode: no curvature
                    break
        failed = Solve(np.zeros_like(z), np.zeros_like(b), np.eye(self.m), None, None)
        return z, b, failed, False, t


def _largest(step: Solve) -> float:
    """The largest change a Newton step makes to any effect."""
    return float(max(np.abs(step.dz).max(initial=0.0), np.abs(step.db).max(initial=0.0)))


def _other_slot(t: dict[str, Any]) -> int:
    """The slot a trial step's terms may use: not the one ``t`` holds its arrays in."""
    return 1 - t["slot"] if t.get("slot") is not None else 0


@dataclass(frozen=True)
class Solve:
    dz: np.ndarray
    db: np.ndarray
    s_inv: np.ndarray  # the dense block of H^-1 (fixed and clip effects)
    a_inv: np.ndarray | None
    x: np.ndarray | None  # A^-1 B
