"""Independent reference of the lumped mesh, contact_model = 4 (lateral.md section 4), for the
two-wheel rig (SpurGearMesh).  Written from the spec text and the brief's exact semantics, not
from the FMU's source.  gearmesh_ref.GearMesh builds it for contact_model = 4 and dispatches
simulate() to it; train_ref.TrainMesh has the same law for a mesh of the train (torsional).

THE LAW (the brief's exact semantics; the teeth are not tracked for the force):
* deflections: forward delta_f = dte (contact model 1's forward penetration), backward
  delta_b = -j_n - dte (j_n the actual normal backlash, model 1's backward offset);
* a flank is in contact iff its delta > 0; onset and separation (delta through 0) are events;
* in contact its total normal force is F = k_eff delta + c_lumped d(delta)/dt, NOT clipped (it may
  be slightly negative just before a damped separation), 0 in the gap; no Hunt-Crossley factor
  (chi ignored), no friction (mu ignored);
* F acts as model 1's normal force of that flank: torques (interface sign) forward -F rAb on A,
  +F rBb on B; backward +F rAb on A, -F rBb on B;
* k_eff = k_lumped, or with k_lumped_varies k_lumped n / eps: eps the transverse contact ratio
  (Geometry.eps) and n the flank's tooth pairs whose s_A at the rigid position lies on the contact
  segment, s_a <= s_A <= s_b (model 1's pair enumeration, gearmesh_ref's module docstring:
  forward pair k at s_A = s_a + u_A - k p_b, backward pair k at s_A = sigma_b1 - u_A + k p_b; the
  lower edge is s_a itself, without model 1's max(delta, 0) shift).  Each change of n is an event.
  With contacts_per_flank < eps the m_c-pitch tracking window s_A >= s_b - m_c p_b applies as in
  model 1 (the brief: "the same tracking as contact_model 1"; no shipped scene uses it);
* outputs: F_fwd, F_bwd = F of the flank (0 in the gap); F_f1, F_f2 (F_b1, F_b2) = F / n_g for the
  objects whose pair is gated (object identity as gearmesh_ref: forward pair k is f1 iff
  k = 0 mod m_c, backward pair k is b1 iff k = 0 mod m_c), n_g the flank's gated pairs (also with
  constant k); n_fwd, n_bwd = n_g of a flank in contact, else 0; P_loss = c_lumped (d delta/dt)^2
  over the flanks in contact; k_mesh = the sum of k_eff over the flanks in contact (the output
  column appended to gearmesh_ref.OUTPUT_NAMES); elastic energy k_eff delta^2 / 2 per flank in
  contact (its jumps at stiffness switches are the energy balance's gate jumps);
* refused (ValueError): shape deviations (tip relief, eccentricity, pitch errors), the slider
  (slider_stiffness != 0), k_lumped <= 0 or not finite, c_lumped < 0 or not finite.

Readings made here where the brief leaves room (reported):
* the gate of a flank NOT in contact is not followed (no events; n is re-derived from the
  position when the flank touches), as model 1's reference does: it changes no output and no force;
* gate ties at a restart are broken by time derivatives (gearmesh_ref's _side rule), an exact
  standstill on a gate boundary counts as inside (closed gate);
* the per-object forces are not clamped either (they are F / n_g).

INTEGRATION as gearmesh_ref: the same state [theta_A, e, w_A, v] (e = dte, v = de/dt), solve_ivp
(DOP853) with the contact state (which flanks touch, which pairs are gated) FIXED inside a call, so
the right-hand side is linear there; terminal events (signed to be >= 0 just after a restart, + ->
- crossings): each flank's delta through 0, and on a flank in contact the gate boundaries as the
periodic functions sin(pi xi / p_b) of u_A = rAb theta_A (lower edges s_A = s_a, upper edges
s_A = s_b, which also covers the window's edge s_b - m_c p_b), and the input table's breakpoints.
Non-terminal guards at the zeros of v (extrema of delta) and of w_A (reversals of every gate
coordinate) catch a sign change hidden inside one step (gearmesh_ref._check_guards), and no step
lets u_A move more than p_b/8.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.integrate import solve_ivp

from . import gearmesh_ref as G
from . import deviations_ref as D

EXTRA_OUTPUT_NAMES = ["k_mesh"]


def output_names(bearing_force=False):
    return list(G.OUTPUT_NAMES) + EXTRA_OUTPUT_NAMES + (G.BEARING_OUTPUT_NAMES if bearing_force else [])


def check_lumped_params(p: dict, where: str = ""):
    """The refusals of contact_model = 4 (ValueError, naming the parameter)."""
    k, c = p["k_lumped"], p["c_lumped"]
    if not (k > 0.0 and math.isfinite(k)):
        raise ValueError(f"{where}k_lumped = {k!r} must be a finite number > 0")
    if not (c >= 0.0 and math.isfinite(c)):
        raise ValueError(f"{where}c_lumped = {c!r} must be a finite number >= 0")
    if D.deviations_active(p):
        raise ValueError(f"{where}contact_model = 4 (the lumped mesh tracks no teeth) cannot take "
                         "shape deviations (tip relief, eccentricity, pitch errors)")
    if p.get("slider_stiffness", 0.0) != 0.0:
        raise ValueError(f"{where}contact_model = 4 cannot run with the slider S "
                         f"(slider_stiffness = {p['slider_stiffness']!r})")


@dataclass
class LumpedState:
    """Contact state between two restarts.  gf, gb: the gated pairs (pair numbers k as in
    gearmesh_ref) of each flank; kf, kb: those of a flank in contact (else empty), i.e. what the
    outputs n_fwd, n_bwd count.  eps >= 1 puts at least one pair in a closed gate, so a flank in
    contact always has kf (kb) non-empty."""
    on_f: bool
    on_b: bool
    gf: tuple
    gb: tuple
    sig: dict = field(default_factory=dict)
    kin: tuple = ()

    @property
    def kf(self):
        return self.gf if self.on_f else ()

    @property
    def kb(self):
        return self.gb if self.on_b else ()

    @property
    def key(self):
        return (self.kf, self.kb)


class LumpedMesh:
    TOL_DELTA = G.GearMesh.TOL_DELTA
    TOL_POS = G.GearMesh.TOL_POS
    _side = G.GearMesh._side

    def __init__(self, model):
        self.m = model
        self.p, self.g = model.p, model.g
        check_lumped_params(self.p)
        self.k = self.p["k_lumped"]
        self.c = self.p["c_lumped"]
        self.varies = bool(self.p["k_lumped_varies"])
        g = self.g
        self.window_active = g.eps > g.m_c + 1e-12

    # ---------------------------------------------------------------- the law
    def k_eff(self, n):
        """k_lumped, or k_lumped n / eps with k_lumped_varies."""
        return self.k * n / self.g.eps if self.varies else self.k

    def _flanks(self, e, v, kf, kb):
        """(flank, delta, d(delta)/dt, n_g, k_eff, F) of each flank in contact."""
        out = []
        if kf:
            k = self.k_eff(len(kf))
            out.append((1, e, v, len(kf), k, k * e + self.c * v))
        if kb:
            d = -self.g.backlash - e
            k = self.k_eff(len(kb))
            out.append((-1, d, -v, len(kb), k, k * d - self.c * v))
        return out

    def _mesh(self, e, v, kf, kb):
        """Mesh torques on A, B (interface sign) and P_loss for a fixed contact state; linear in
        (e, v) between events (F is not clipped: the state changes only at delta = 0)."""
        rAb, rBb = self.g.rAb, self.g.rBb
        mA = mB = pl = 0.0
        for flank, _d, dd, _n, _k, F in self._flanks(e, v, kf, kb):
            mA -= flank * F * rAb
            mB += flank * F * rBb
            pl += self.c * dd * dd
        return mA, mB, pl

    def _accel(self, y, kf, kb, tauA, tauB):
        g, p = self.g, self.p
        wB = (g.rAb * y[2] - y[3]) / g.rBb
        mA, mB, _ = self._mesh(y[1], y[3], kf, kb)
        return (tauA + mA) / p["J_A"], (tauB - p["c_load"] * wB + mB) / p["J_B"]

    # ---------------------------------------------------------------- classification
    def _sA(self, flank, uA, k):
        g = self.g
        return g.s_a + uA - k * g.p_b if flank == 1 else g.sigma_b1 - uA + k * g.p_b

    def _candidates(self, flank, uA):
        """Pair numbers whose s_A can lie in [min(s_a, s_b - m_c p_b), s_b], one pair margin."""
        g = self.g
        lo_s = min(g.s_a, g.s_b - g.m_c * g.p_b)
        if flank == 1:      # s_A = s_a + uA - k p_b
            a, b = (g.s_a + uA - g.s_b) / g.p_b, (g.s_a + uA - lo_s) / g.p_b
        else:               # s_A = sigma_b1 - uA + k p_b
            a, b = (lo_s - g.sigma_b1 + uA) / g.p_b, (g.s_b - g.sigma_b1 + uA) / g.p_b
        return range(math.floor(a) - 1, math.ceil(b) + 2)

    def _periodic_sign(self, xi, xi1, xi2):
        """Sign s with s sin(pi xi / p_b) >= 0 just after now (gearmesh_ref's rule)."""
        p_b = self.g.p_b
        n = round(xi / p_b)
        r = xi - n * p_b
        parity = -1.0 if n % 2 else 1.0
        return parity * (1.0 if self._side(r, xi1, xi2, self.TOL_POS) else -1.0)

    def _decide(self, y, acc, tie_aware=True):
        g, p = self.g, self.p
        rAb, rBb = g.rAb, g.rBb
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = rAb * thA
        wB = (rAb * wA - v) / rBb
        aA, aB = acc
        e2 = rAb * aA - rBb * aB

        def side(c, c1, c2, tol):
            return self._side(c, c1, c2, tol) if tie_aware else c >= -tol

        on_f = side(e, v, e2, self.TOL_DELTA)
        on_b = p["backward_contacts"] and side(-g.backlash - e, -v, -e2, self.TOL_DELTA)
        sig = {"df": 1.0 if on_f else -1.0}
        if p["backward_contacts"]:
            sig["db"] = 1.0 if on_b else -1.0
        lo_win = g.s_b - g.m_c * g.p_b
        gated = {}
        for flank in (1, -1):
            r1, r2 = flank * rAb * wA, flank * rAb * aA      # d s_A/dt, d2 s_A/dt2
            ks = []
            for k in self._candidates(flank, uA):
                sA = self._sA(flank, uA, k)
                ok = side(g.s_b - sA, -r1, -r2, self.TOL_POS) and side(sA - g.s_a, r1, r2, self.TOL_POS)
                if ok and self.window_active:
                    ok = side(sA - lo_win, r1, r2, self.TOL_POS)
                if ok:
                    ks.append(k)
            gated[flank] = tuple(ks)
        # gate event signs (used while the flank is in contact): xi = u_A - c0, zero (mod p_b) at
        # every pair's boundary; forward upper c0 = s_b - s_a, lower 0; backward upper
        # sigma_b1 - s_b, lower sigma_b1 - s_a
        for name, c0 in self._gate_offsets():
            sig[name] = self._periodic_sign(uA - c0, rAb * wA, rAb * aA)
        kin = (uA, wA, wB, aA, aB, e, v, e2)
        return LumpedState(on_f, bool(on_b), gated[1], gated[-1], sig, kin)

    def _gate_offsets(self):
        g = self.g
        return (("uf", g.s_b - g.s_a), ("lf", 0.0),
                ("ub", g.sigma_b1 - g.s_b), ("lb", g.sigma_b1 - g.s_a))

    def _classify(self, y, tauA, tauB):
        """Contact state just after a restart; ties need the accelerations, which depend on the
        state: iterate from the state in which every tie counts as inside (gearmesh_ref)."""
        prelim = self._decide(y, (0.0, 0.0), tie_aware=False)
        cfg = self._decide(y, self._accel(y, prelim.kf, prelim.kb, tauA, tauB))
        for _ in range(4):
            new = self._decide(y, self._accel(y, cfg.kf, cfg.kb, tauA, tauB))
            if new.key == cfg.key and new.on_f == cfg.on_f and new.on_b == cfg.on_b:
                return new
            cfg = new
        return cfg

    # ---------------------------------------------------------------- events
    def _make_events(self, cfg):
        g, p = self.g, self.p
        rAb, p_b = g.rAb, g.p_b
        kp = math.pi / p_b
        uA, wA, _wB, aA, _aB, e, v, e2 = cfg.kin
        evs = []

        def add(fn, c, c1, c2, tol, band):
            after = self._side(c, c1, c2, tol)
            off = 0.0
            if after and c < band:
                off = band - c
            elif not after and c > -band:
                off = -(band + c)
            if off != 0.0:
                raw = fn
                fn = lambda t, yy: raw(t, yy) + off
            fn.terminal = True
            fn.direction = -1.0
            fn.band = band
            evs.append(fn)

        s = cfg.sig
        sdf = s["df"]
        add(lambda t, yy: sdf * yy[1], sdf * e, sdf * v, sdf * e2, self.TOL_DELTA, 1e-20)
        if p["backward_contacts"]:
            sdb, jb = s["db"], g.backlash
            add(lambda t, yy: sdb * (-jb - yy[1]), sdb * (-jb - e), -sdb * v, -sdb * e2,
                self.TOL_DELTA, 1e-20)
        for name, c0 in self._gate_offsets():
            if not (cfg.on_f if name.endswith("f") else cfg.on_b):
                continue
            sg = s[name]
            xi = uA - c0
            sn, cs = math.sin(kp * xi), math.cos(kp * xi)
            w1 = kp * rAb * wA
            add(lambda t, yy, sg=sg, c0=c0: sg * math.sin(kp * (rAb * yy[0] - c0)),
                sg * sn, sg * cs * w1, sg * (cs * kp * rAb * aA - sn * w1 * w1),
                kp * self.TOL_POS, 1e-12)
        guards = []
        for fn in (lambda t, yy: yy[3], lambda t, yy: yy[2]):
            fn.terminal = False
            fn.direction = 0.0
            guards.append(fn)
        return evs, guards

    # ---------------------------------------------------------------- outputs
    def outputs(self, t, y, cfg, bearing=False):
        g = self.g
        thA, e, wA, v = y[0], y[1], y[2], y[3]
        uA = g.rAb * thA
        F = {"f1": 0.0, "f2": 0.0, "b1": 0.0, "b2": 0.0}
        Ffl = {1: 0.0, -1: 0.0}
        mA = mB = pl = kmesh = 0.0
        for flank, _d, dd, n, k, Fl in self._flanks(e, v, cfg.kf, cfg.kb):
            Ffl[flank] = Fl
            ks = cfg.kf if flank == 1 else cfg.kb
            for kk in ks:
                name = ("f" if flank == 1 else "b") + ("1" if kk % g.m_c == 0 else "2")
                F[name] += Fl / n
            mA -= flank * Fl * g.rAb
            mB += flank * Fl * g.rBb
            pl += self.c * dd * dd
            kmesh += k
        row = [t, thA, (uA - e) / g.rBb, wA, (g.rAb * wA - v) / g.rBb, e,
               F["f1"], F["f2"], F["b1"], F["b2"], Ffl[1], Ffl[-1], len(cfg.kf), len(cfg.kb),
               mA, mB, pl, kmesh]
        if bearing:
            pairs = [(flank, 0, 0.0, 0.0, Fl, 0.0, 0.0) for flank, Fl in Ffl.items() if Fl != 0.0]
            row += list(G.mesh_force_on_B(g, pairs))
        return row

    # ---------------------------------------------------------------- energy helpers
    def elastic_energy(self, y, cfg):
        """k_eff delta^2 / 2 over the flanks in contact [J]."""
        return sum(0.5 * k * d * d for _f, d, _dd, _n, k, _F in self._flanks(y[1], y[3], cfg.kf, cfg.kb))

    def kinetic_energy(self, y):
        return self.m.kinetic_energy(y)

    def delta_scale(self, inputs):
        """Characteristic deflection [m]: the line force of the largest input torque (at least
        1 N) on the softest spring."""
        g = self.g
        ta, tb = inputs.max_abs()
        F = max(ta / g.rAb, tb / g.rBb, 1.0)
        return F / self.k_eff(1)

    # ---------------------------------------------------------------- main loop
    def simulate(self, stop_time, output_interval, inputs=None, rtol=1e-10, method="DOP853",
                 energy=False, max_restarts=2_000_000, perturb_w_A=0.0, y0=None,
                 bearing_force=False, output_step_cap=True):
        """As GearMesh.simulate; outputs gearmesh_ref.OUTPUT_NAMES + k_mesh (+ F_B_x, F_B_y).
        energy: the state carries W_ext (work of tau_A, tau_B, c_load) and W_loss (integral of
        P_loss); res.energy = {"segments", "jumps"} as GearMesh's."""
        p, g = self.p, self.g
        if bearing_force and g.internal:
            raise NotImplementedError("bearing force outputs of an internal pair are not "
                                      "implemented in this reference")
        if inputs is None:
            inputs = G.InputTable.constant(p["tau_A"], p["tau_B"])
        J_A, J_B, c_load = p["J_A"], p["J_B"], p["c_load"]
        rAb, rBb = g.rAb, g.rBb
        y = self.m.initial_state() if y0 is None else np.array(y0, float)
        y[2] += perturb_w_A
        y[3] += rAb * perturb_w_A
        if energy:
            y = np.concatenate([y[:4], [0.0, 0.0]])
        dscale = self.delta_scale(inputs)
        wscale = max(1.0, abs(p["w_A_start"]), abs(p["w_B_start"]))
        atol = np.array([1.0, dscale, wscale, dscale * 1e4] + ([1.0, 1.0] if energy else [])) * rtol
        n_grid = int(round(stop_time / output_interval))
        grid = np.arange(n_grid + 1) * output_interval
        grid[-1] = stop_time
        mesh = self._mesh

        def make_rhs(cfg, seg):
            t0, a0, da, b0, db = seg
            kf, kb = cfg.kf, cfg.kb

            def rhs(t, yy):
                wA, v = yy[2], yy[3]
                wB = (rAb * wA - v) / rBb
                tauA = a0 + da * (t - t0)
                tauB = b0 + db * (t - t0)
                mA, mB, pl = mesh(yy[1], v, kf, kb)
                aA = (tauA + mA) / J_A
                aB = (tauB - c_load * wB + mB) / J_B
                if energy:
                    return [wA, v, aA, rAb * aA - rBb * aB,
                            tauA * wA + tauB * wB - c_load * wB * wB, pl]
                return [wA, v, aA, rAb * aA - rBb * aB]
            return rhs

        tau_now = lambda tt, sg: (sg[1] + sg[2] * (tt - sg[0]), sg[3] + sg[4] * (tt - sg[0]))
        t = 0.0
        seg = inputs.segment(t)
        cfg = self._classify(y, *tau_now(t, seg))
        seg_max = 20.0 * output_interval
        segments, events, jumps = [], [], []
        n_restart = n_missed = n_hidden = 0
        while t < stop_time:
            seg = inputs.segment(t)
            t_hi = min(inputs.next_break(t), stop_time, t + seg_max)
            if stop_time - t_hi < 1e-3 * output_interval:
                t_hi = min(inputs.next_break(t), stop_time)
            uA_, wA_, _wB, aA_ = cfg.kin[:4]
            line_speed = abs(rAb * wA_) + abs(rAb * aA_) * (t_hi - t)
            max_step = min(output_interval if output_step_cap else np.inf,
                           g.p_b / (8.0 * line_speed + 1e-300))
            evs, guards = self._make_events(cfg)
            sol = solve_ivp(make_rhs(cfg, seg), (t, t_hi), y, method=method, rtol=rtol, atol=atol,
                            events=evs + guards, dense_output=True, max_step=max_step)
            if sol.status < 0:
                raise RuntimeError(f"solve_ivp failed at t = {t}: {sol.message}")
            t_new = float(sol.t[-1])
            y_new = sol.y[:, -1].copy()
            located = sol.status == 1
            t_cut = G.GearMesh._check_guards(self, sol, t, evs, len(guards))
            if t_cut is not None:
                t_new = t_cut
                y_new = np.asarray(sol.sol(t_cut), dtype=float).copy()
                located = True
                n_hidden += 1
            segments.append((t, t_new, sol.sol, cfg))
            n_restart += 1
            if n_restart > max_restarts:
                raise RuntimeError(f"more than {max_restarts} restarts (chattering?) at t = {t_new}")
            seg_new = inputs.segment(t_new) if t_new < stop_time else seg
            new = self._classify(y_new, *tau_now(t_new, seg_new))
            if new.key != cfg.key:
                if not located:
                    n_missed += 1
                events.append((t_new, y_new, cfg, new))
                if energy:
                    jumps.append((t_new, y_new, cfg, new))
            t, y, cfg = t_new, y_new, new

        # ---- sample (as GearMesh.simulate: grid rows, two rows per event, time-sorted)
        rows = []
        seg_t0 = [s_[0] for s_ in segments]
        for tg in grid:
            i = bisect.bisect_right(seg_t0, tg) - 1
            i = min(max(i, 0), len(segments) - 1)
            t0, t1, solf, c = segments[i]
            yy = solf(tg) if t1 > t0 else solf(t0)
            rows.append(self.outputs(tg, yy, c, bearing_force))
        merged = []
        for ev in events:
            if merged and ev[0] == merged[-1][0]:
                merged[-1] = (ev[0], ev[1], merged[-1][2], ev[3])
            else:
                merged.append(ev)
        ev_list = []
        for te, ye, cb, ca in merged:
            if cb.key == ca.key:
                continue
            rows.append(self.outputs(te, ye, cb, bearing_force))
            rows.append(self.outputs(te, ye, ca, bearing_force))
            ev_list.append((te, len(cb.kf), len(cb.kb), len(ca.kf), len(ca.kb)))
        order = sorted(range(len(rows)), key=lambda i: (rows[i][0], 0 if i < len(grid) else 1, i))
        ev_times = {e_[0] for e_ in ev_list}
        table = np.array([rows[i] for i in order if not (i < len(grid) and rows[i][0] in ev_times)])
        res = G.Result(output_names(bearing_force), table, ev_list, n_restart, n_missed=n_missed,
                       n_hidden=n_hidden)
        if energy:
            res.energy = {"segments": segments, "jumps": jumps}
        return res
