# curvecheck's calibration solver: mrcal's Python API driven with the corners that curvecheck detected.
#
# Why Python: in mrcal 2.2 the seeding (mrcal.seed_stereographic) and the projection uncertainty
# (mrcal.projection_uncertainty, mrcal.projection_diff) exist only in the Python layer. They are mrcal's reference
# implementation, the same calls mrcal-calibrate-cameras makes; re-deriving them in C++ would duplicate mrcal and
# risk getting the covariance subtly wrong. The C++ side (calibrate/calibrate.cc) owns detection, the model choice
# and all I/O; this script only solves and measures. It is embedded in the binary and run with /usr/bin/python3.
#
# Input (JSON file, argv[1]):
#   imagersize [w, h]; board [nx, ny] (corners per row, rows); spacing_mm; focal_px (seed);
#   observations: per photo a list of nx*ny [x, y, weight] (weight < 0: not detected), row-major;
#   lensmodels: candidates; halves: [[photo indices], [photo indices]] or null (no cross-validation);
#   grid [gx, gy]: uncertainty / cross-validation grid; distance_mm: null = at infinity; out_dir; seed.
#   structure_grid [cx, cy]: cells for the residual-structure test.
# Output (JSON file, argv[2]): one entry per candidate (see Candidate() below).
import json
import sys
import time

import numpy as np
import numpysane as nps
import mrcal


def solve(inp, observations, lensmodel):
    """Seeds and solves one monocular calibration; returns optimization_inputs after the final solve.

    The sequence follows mrcal's own tool: stereographic seed, geometry-only solve, core solve, then the full model
    (splined models keep the core fixed: it is redundant with the spline), outlier rejection and regularization on,
    with the board's warp (a real monitor panel is not perfectly flat)."""
    imagersizes = np.array([inp['imagersize']], dtype=np.int32)
    nframes = observations.shape[0]
    ifc = np.ascontiguousarray(nps.transpose(np.array([np.arange(nframes), np.zeros(nframes)], dtype=np.int32)))
    ifcice = np.ascontiguousarray(nps.glue(ifc, ifc[:, (1,)] - 1, axis=-1))
    spacing = inp['spacing_mm']
    intrinsics, extrinsics, frames = mrcal.seed_stereographic(
        imagersizes=imagersizes, focal_estimate=inp['focal_px'], indices_frame_camera=ifc,
        observations=observations, object_spacing=spacing)
    common = dict(points=None, observations_point=None, indices_point_camintrinsics_camextrinsics=None,
                  imagersizes=imagersizes, calibration_object_spacing=spacing, verbose=False)
    for core in (False, True):
        mrcal.optimize(intrinsics, extrinsics, frames, None, observations, ifcice, None, None,
                       'LENSMODEL_STEREOGRAPHIC', imagersizes=imagersizes, do_optimize_intrinsics_core=core,
                       do_optimize_intrinsics_distortions=False, do_optimize_calobject_warp=False,
                       calibration_object_spacing=spacing, do_apply_outlier_rejection=False,
                       do_apply_regularization=False, verbose=False)
    if lensmodel.endswith('fov_x_deg=auto'):
        # The spline's domain: the horizontal field of view of the stereographic core fitted above (its
        # projection is q = 2 f tan(theta / 2)), plus 10% so that the imager's edges are inside the knots.
        fx, _, cx, _ = intrinsics[0, :4]
        half_deg = np.degrees(2 * np.arctan(max(cx + 0.5, inp['imagersize'][0] - 0.5 - cx) / (2 * fx)))
        lensmodel = lensmodel.replace('auto', str(int(np.ceil(2 * half_deg * 1.1))))
    extra = mrcal.lensmodel_num_params(lensmodel) - intrinsics.shape[-1]
    rng = np.random.default_rng(inp['seed'])
    new = (rng.random((1, extra)) - 0.5) * 2e-6
    if lensmodel.startswith('LENSMODEL_OPENCV') and int(lensmodel[16:]) >= 8:
        new[:, 5:8] *= 1e-3  # rational terms near 0: keeps the ratio away from 0/0 (mrcal's tool does the same)
    intrinsics = nps.glue(intrinsics, new, axis=-1)
    splined = lensmodel.startswith('LENSMODEL_SPLINED')
    oi = dict(intrinsics=intrinsics, extrinsics_rt_fromref=extrinsics, frames_rt_toref=frames,
              observations_board=observations, indices_frame_camintrinsics_camextrinsics=ifcice,
              lensmodel=lensmodel, calobject_warp=None, do_optimize_intrinsics_core=not splined,
              do_optimize_intrinsics_distortions=True, do_optimize_extrinsics=True, do_optimize_frames=True,
              do_optimize_calobject_warp=False, do_apply_outlier_rejection=True, do_apply_regularization=True,
              **common)
    mrcal.optimize(**oi)
    oi['calobject_warp'] = np.array((0., 0.))
    oi['do_optimize_calobject_warp'] = True
    if not splined and not inp.get('regularize_parametric', False):
        # mrcal's regularization pulls the distortions toward 0: a bias that its uncertainty does not include, and
        # that is visible for strong lenses (0.2-0.3 px in calibrate_test). Parametric models are determined by
        # the data, so their final solve runs without it (mrcal-calibrate-cameras --skip-regularization does
        # the same: regularized first, then unregularized). Splined models keep it: their knots outside the
        # data are determined by nothing else.
        mrcal.optimize(**oi)
        oi['do_apply_regularization'] = False
    stats = mrcal.optimize(**oi)
    return oi, stats, lensmodel


def grid_pixels(inp):
    w, h = inp['imagersize']
    gx, gy = inp['grid']
    xs = (np.arange(gx) + 0.5) * w / gx - 0.5
    ys = (np.arange(gy) + 0.5) * h / gy - 0.5
    return np.ascontiguousarray(nps.mv(nps.cat(*np.meshgrid(xs, ys)), 0, -1))  # (gy, gx, 2)


def uncertainty(model, q, distance_mm):
    """Worst-direction standard deviation (px) of projection at pixels q, of points at distance_mm along their
    rays (None: at infinity), from the calibration's own Jacobian (mrcal's method)."""
    v = mrcal.unproject(q, *model.intrinsics(), normalize=True)
    if distance_mm is None:
        return mrcal.projection_uncertainty(v, model=model, atinfinity=True, what='worstdirection-stdev')
    return mrcal.projection_uncertainty(v * distance_mm, model=model, what='worstdirection-stdev')


def intrinsics_covariance(oi, lensmodel):
    """The covariance of the intrinsics (mrcal's order and units), marginal over the board poses, from the
    calibration's own Jacobian, as mrcal's projection uncertainty computes it (mrcal 2.2 model_analysis.py,
    _projection_uncertainty and its docstring; http://mrcal.secretsauce.net/uncertainty.html):
      Var(b*) = s^2 inv(J*t J*) J*[obs]t J*[obs] inv(J*t J*)   (s^2 inv(J*t J*) without regularization rows),
      Var(b)  = D Var(b*) D,
    with b* mrcal's packed (unitless) state, D its unpacking scale (mrcal.unpack_state on ones) and s the observed
    pixel noise (the std of the board residuals, mrcal's default). Intrinsics that were not optimized (the core
    of a splined model) get 0. Returns (n x n list, dof = inlier measurements - states, s)."""
    _, x, jpacked, factorization = mrcal.optimizer_callback(**oi)
    if factorization is None:
        raise Exception("the calibration's JtJ could not be factored")
    n = int(mrcal.lensmodel_num_params(lensmodel))
    ncore = 4 if mrcal.lensmodel_metadata_and_config(lensmodel)['has_core'] else 0
    i0 = 0 if oi.get('do_optimize_intrinsics_core') else ncore
    i1 = n if oi.get('do_optimize_intrinsics_distortions') else ncore
    full = np.zeros((n, n))
    m = i1 - i0
    nstate = jpacked.shape[1]
    if m <= 0:
        return full.tolist(), 0, 0.0
    istate = mrcal.state_index_intrinsics(0, **oi)
    e = np.zeros((m, nstate))
    e[np.arange(m), istate + np.arange(m)] = 1
    a = factorization.solve_xt_JtJ_bt(e)  # e inv(J*t J*), shape (m, nstate)
    nobs = mrcal.num_measurements_boards(**oi)
    if nobs == mrcal.num_measurements(**oi):
        var = nps.matmult(a, nps.transpose(e))
    else:
        b = jpacked[:nobs].dot(nps.transpose(a))  # J*[obs] inv(J*t J*) e^T, shape (nobs, m)
        var = nps.matmult(nps.transpose(b), b)
    d = np.ones(nstate)
    mrcal.unpack_state(d, **oi)
    dscale = d[istate:istate + m]
    s = float(np.std(mrcal.residuals_chessboard(oi, residuals=x).ravel()))
    full[i0:i1, i0:i1] = s * s * dscale[:, None] * var * dscale[None, :]
    inliers = int(np.sum(oi['observations_board'][..., 2] > 0))
    return full.tolist(), 2 * inliers - nstate, s


def misfit_field(oi, lensmodel, seed):
    """The lens-model misfit of this calibration, measured from its own residuals' correlation (mrcal's diagnosis of
    a model that does not fit: residuals correlated across the imager; the same family as the screen fit's
    lens-model-misfit row, analysis/screen_fit_misfit.cc): the true lens departs from the model by a stationary
    Gaussian field delta(q) over the image, common to every photo, independent per coordinate, covariance
    s^2 exp(-d^2 / 2 L^2). For two inlier corners a, b of DIFFERENT photos (independent noise) at image distance d,
    E[r_a . r_b / 2] = s^2 kappa_ab(L), kappa from the field's residual after the fit's projection,
    (I - J (J^T J)^-1 J^T) Phi (the part of the field that the intrinsics and poses absorb leaves no residual);
    Phi: 200 random Fourier features of the unit field (Rahimi-Recht). Pairs are binned by distance (up to 24
    corner spacings); for each L of a grid (3 to 60% of the image width) s^2 is the weighted least-squares scale
    (weights: the bins' pair counts), and the L of the lowest chi-square is kept. The intrinsics' covariance from the
    field: s^2 A Phi2 Phi2^T A^T, A the intrinsics rows of (J^T J)^-1 J^T in mrcal's unpacked units. Returns a dict
    (variance_px2 = 0 when the residuals show no positive correlation)."""
    _, x, jpacked, _ = mrcal.optimizer_callback(**oi)
    nobs = mrcal.num_measurements_boards(**oi)
    obs = oi['observations_board']
    nframes = obs.shape[0]
    per = obs.shape[1] * obs.shape[2]
    q = obs[..., :2].reshape(-1, 2)
    inl = obs[..., 2].reshape(-1) > 0
    frame = np.repeat(np.arange(nframes), per)
    idx = np.nonzero(inl)[0]
    rows = np.stack([2 * idx, 2 * idx + 1], axis=1).reshape(-1)
    jd = jpacked[:nobs].toarray()[rows]
    r = np.asarray(x[:nobs]).reshape(-1, 2)[idx]
    p, f = q[idx], frame[idx]
    n = len(idx)
    sigma2 = float(np.mean(r * r))
    m = np.linalg.pinv(jd.T @ jd, rcond=1e-12)
    nint = int(mrcal.lensmodel_num_params(lensmodel))
    istate = mrcal.state_index_intrinsics(0, **oi)
    d = np.ones(jd.shape[1])
    mrcal.unpack_state(d, **oi)
    a = (m[istate:istate + nint] @ jd.T) * d[istate:istate + nint, None]  # unpacked, nint x 2n
    # The pair statistics on at most 2000 corners (a seeded subset: the pair matrices are n x n).
    sub = np.arange(n)
    if n > 2000:
        sub = np.sort(np.random.default_rng(seed + 11).choice(n, 2000, replace=False))
    p_all, r = p, r[sub]
    p, f = p[sub], f[sub]
    ns = len(sub)
    dist = np.sqrt(np.sum((p[:, None, :] - p[None, :, :]) ** 2, axis=-1))
    same = f[:, None] == f[None, :]
    near = np.where(same & ~np.eye(ns, dtype=bool), dist, np.inf)
    spacing = float(np.median(np.min(near, axis=1)))
    upper = np.triu(np.ones((ns, ns), dtype=bool), 1) & ~same
    edges = spacing * np.array([0, 0.5, 1.5, 3, 6, 12, 24])
    masks, counts, stats = [], [], []
    rr = r @ r.T
    for lo, hi in zip(edges[:-1], edges[1:]):
        mk = upper & (dist >= lo) & (dist < hi)
        c = int(np.sum(mk))
        if c < 50:
            continue
        masks.append(mk)
        counts.append(c)
        stats.append(float(np.mean(rr[mk])) / 2)
    out = dict(variance_px2=0.0, variance_sd_px2=0.0, length_px=0.0, spacing_px=spacing, sigma_px=np.sqrt(sigma2),
               lags=[dict(pairs=c, statistic_px2=s) for c, s in zip(counts, stats)],
               covariance=np.zeros((nint, nint)).tolist())
    if len(stats) < 2:
        return out
    stats = np.array(stats)
    weights = np.array(counts, dtype=float)
    rng = np.random.default_rng(seed + 7)
    nf = 200
    omega = rng.standard_normal((nf, 2))
    phase = rng.uniform(0, 2 * np.pi, nf)
    width = float(oi['imagersizes'][0][0])
    best = None
    for frac in (0.03, 0.08, 0.15, 0.3, 0.6):
        length = frac * width
        phi = np.sqrt(2.0 / nf) * np.cos(p_all @ omega.T / length + phase)
        phi2 = np.zeros((2 * n, 2 * nf))
        phi2[0::2, :nf] = phi
        phi2[1::2, nf:] = phi
        res = phi2 - jd @ (m @ (jd.T @ phi2))
        rx, ry = res[0::2][sub], res[1::2][sub]
        g = rx @ rx.T + ry @ ry.T
        e = np.array([float(np.mean(g[mk])) / 2 for mk in masks])
        den = float(np.sum(weights * e * e))
        if den <= 0:
            continue
        s2 = float(np.sum(weights * e * stats)) / den
        chi2 = float(np.sum(weights * (stats - s2 * e) ** 2))
        if best is None or chi2 < best[0]:
            best = (chi2, s2, length, phi2, e, den)
    if best is None or best[1] <= 0:
        return out
    _, s2, length, phi2, e, den = best
    ap = a @ phi2
    out.update(variance_px2=s2, length_px=length,
               # under noise alone each bin's statistic has a standard error of about sigma^2 / sqrt(2 pairs)
               # (pairs taken as independent: optimistic)
               variance_sd_px2=float(np.sqrt(np.sum(weights ** 2 * e ** 2 * sigma2 ** 2 / (2 * weights)))) / den,
               expected_per_unit=e.tolist(), covariance=(s2 * ap @ ap.T).tolist())
    return out


def observed_mask(q, observations, inp):
    """Grid points near observed corners: the region where the calibration has data."""
    pts = observations[..., :2][observations[..., 2] > 0]
    w, h = inp['imagersize']
    gx, gy = inp['grid']
    radius = 0.75 * np.hypot(w / gx, h / gy)
    mask = np.zeros(q.shape[:-1], dtype=bool)
    flat = q.reshape(-1, 2)
    m = mask.reshape(-1)
    for i in range(flat.shape[0]):
        m[i] = np.any(np.sum((pts - flat[i]) ** 2, axis=-1) < radius * radius)
    return mask


def structure(inp, observations, residuals):
    """Residual structure: the imager is cut into cx x cy cells; in each cell with >= 8 inliers the mean residual
    vector is compared with its standard error. T = sum n |mean|^2 / sigma^2 is chi-square with 2 * cells degrees
    of freedom when the residuals are unstructured noise (sigma: this fit's own per-axis residual RMS). Reported as
    z = (T - dof) / sqrt(2 dof); a lens model that misses a term leaves a coherent pattern and a large z."""
    w, h = inp['imagersize']
    cx, cy = inp['structure_grid']
    inl = observations[..., 2] > 0
    q = observations[..., :2][inl]
    r = residuals[inl]
    sigma2 = np.mean(r * r)
    ix = np.clip((q[:, 0] + 0.5) * cx / w, 0, cx - 1).astype(int)
    iy = np.clip((q[:, 1] + 0.5) * cy / h, 0, cy - 1).astype(int)
    t, cells = 0.0, 0
    for c in range(cx * cy):
        sel = (iy * cx + ix) == c
        n = int(np.sum(sel))
        if n < 8:
            continue
        mean = np.mean(r[sel], axis=0)
        t += n * float(np.sum(mean * mean)) / sigma2
        cells += 1
    dof = 2 * cells
    return dict(cells=cells, chi2_per_dof=t / dof if dof else 0.0,
                z=(t - dof) / np.sqrt(2 * dof) if dof else 0.0)


def candidate(inp, observations, lensmodel, index):
    detected = observations[..., 2] > 0  # before the solve: mrcal marks outliers in place
    t0 = time.time()
    oi, stats, lensmodel = solve(inp, observations, lensmodel)
    t_solve = time.time() - t0
    model = mrcal.cameramodel(optimization_inputs=oi, icam_intrinsics=0)
    nx, ny = inp['board']
    nframes = observations.shape[0]
    residuals = stats['x'][:nframes * nx * ny * 2].reshape(nframes, ny, nx, 2)
    obs_after = oi['observations_board']  # outliers now carry weight < 0
    inl = obs_after[..., 2] > 0
    per_photo = [float(np.sqrt(np.sum(residuals[i][inl[i]] ** 2) / max(1, np.sum(inl[i])))) for i in range(nframes)]
    q = grid_pixels(inp)
    sig = uncertainty(model, q, inp['distance_mm'])
    mask = observed_mask(q, obs_after, inp)
    out = dict(lensmodel=lensmodel, nparams=int(mrcal.lensmodel_num_params(lensmodel)),
               rms_px=float(np.sqrt(np.mean(residuals[inl] ** 2) * 2)),
               worst_px=float(np.sqrt(np.max(np.sum(residuals[inl] ** 2, axis=-1)))),
               noutliers=int(np.sum(~inl & detected)), ninliers=int(np.sum(inl)),
               per_photo_rms_px=per_photo, solve_s=t_solve,
               residuals_px=residuals.reshape(nframes, -1, 2).tolist(),
               inlier=inl.reshape(nframes, -1).tolist(),
               intrinsics=model.intrinsics()[1].tolist(),
               cam_from_board_rt=oi['frames_rt_toref'].tolist(),
               structure=structure(inp, obs_after, residuals),
               uncertainty=dict(grid_px=q.reshape(-1, 2).tolist(),
                                sigma_px=sig.reshape(-1).tolist(),
                                observed=mask.reshape(-1).tolist()))
    cov, dof, s = intrinsics_covariance(oi, lensmodel)
    out['intrinsics_covariance'] = dict(covariance=cov, dof=dof, observed_pixel_uncertainty_px=s)
    try:
        out['misfit'] = misfit_field(oi, lensmodel, inp['seed'])
    except Exception as e:  # reported, not fatal: the noise covariance stands alone
        out['misfit'] = dict(error=f"{type(e).__name__}: {e}")
    path = f"{inp['out_dir']}/candidate-{index}.cameramodel"
    model.write(path, note=f"curvecheck calibrate: candidate {lensmodel}")
    out['model_path'] = path
    if inp['halves']:
        t0 = time.time()
        halves = []
        for h in inp['halves']:
            oih, _, _ = solve(inp, np.ascontiguousarray(observations[h]), lensmodel)
            halves.append(mrcal.cameramodel(optimization_inputs=oih, icam_intrinsics=0))
        gx, gy = inp['grid']
        distance = inp['distance_mm']
        # projection_diff starts its implied-rotation fit from np.random.random (mrcal 2.2 model_analysis.py,
        # unseeded): seeded here, the same photos give the same ratio on every run.
        np.random.seed(inp['seed'])
        difflen, _, q0, _ = mrcal.projection_diff(halves, gridn_width=gx, gridn_height=gy, distance=distance,
                                                  use_uncertainties=True)
        expected = np.sqrt(uncertainty(halves[0], q0, distance) ** 2 + uncertainty(halves[1], q0, distance) ** 2)
        m = observed_mask(q0, obs_after, inp)
        m &= np.isfinite(difflen) & np.isfinite(expected)
        ratio = difflen[m] / expected[m]
        out['crossval'] = dict(rms_diff_px=float(np.sqrt(np.mean(difflen[m] ** 2))),
                               rms_expected_px=float(np.sqrt(np.mean(expected[m] ** 2))),
                               ratio_median=float(np.median(ratio)) if ratio.size else float('inf'),
                               ratio_p90=float(np.percentile(ratio, 90)) if ratio.size else float('inf'),
                               points=int(np.sum(m)), solve_s=time.time() - t0)
    return out


def finite(o):
    """JSON has no NaN or infinity: they become null (read back as NaN)."""
    if isinstance(o, float):
        return o if np.isfinite(o) else None
    if isinstance(o, dict):
        return {k: finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [finite(v) for v in o]
    return o


def main():
    with open(sys.argv[1]) as f:
        inp = json.load(f)
    observations = np.array(inp['observations'], dtype=float)
    nx, ny = inp['board']
    observations = observations.reshape(observations.shape[0], ny, nx, 3)
    results = []
    for i, lensmodel in enumerate(inp['lensmodels']):
        try:
            results.append(candidate(inp, observations.copy(), lensmodel, i))
        except Exception as e:  # a failed candidate is reported, not fatal: others may fit
            results.append(dict(lensmodel=lensmodel, error=f"{type(e).__name__}: {e}"))
    with open(sys.argv[2], 'w') as f:
        json.dump(finite(dict(format='curvecheck.mrcal_solve/1', candidates=results)), f, allow_nan=False)


main()
