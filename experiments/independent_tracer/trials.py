#!/usr/bin/python3
"""Seeded trials of the independent tracer (trace.py) through curvecheck, and their summary.

  trials.py run CURVECHECK OUTDIR SEED0 TRIALS_PER_CELL SHARD SHARDS [key=value ...]
  trials.py summary OUTDIR
  trials.py reanalyze CURVECHECK OUTDIR SUFFIX   (a run's kept photos through another binary: OUTDIR/re_SUFFIX.csv)

A trial: a camera at distance d from the true screen centre (+-5%) and yaw y about it (+-2 deg, +-30 mm in height),
looking at the centre; `curvecheck render` draws the exact correction for that position on the spec's 1000R; the
tracer photographs it on a screen of true radius R (drawn from rfactors x 1000 mm), with a fill factor and a
sampling drawn per trial; `curvecheck analyze` measures it. Cells: dists x yaws. Keys (defaults): res=2400x1600,
dists=1000,2000,3000, yaws=0,20,40, fills=0.7,1, samplings=jitter2,regular2,real (2 x 2 rays jittered; 2 x 2 rays
on a regular grid (jitter1, regular1: one ray per pixel); real: 4 x 4 jittered rays, blur 0.6 px, noise 1%, JPEG 92;
webcam: 4 x 4 jittered rays, blur 0.8 px, noise 2%, JPEG 85), rfactors=1,0.92,1.08, keep=1 (keep the
photos), only=SEED (one trial), pattern=checkerboard|apriltag (tags=16x4: the tag grid), k1=K (a radial k1 the camera model is told), noise_seed_offset=K (the tracer's
rays and noise drawn from seed + K, the scene unchanged: two runs differ only in their random part). One CSV per shard
(OUTDIR/trials_SHARD.csv): the radius, its sigma and 95% interval against the truth, the chosen model, the fit's
noise, the detections' RMS error per coordinate against the truth and the verdict. The verdict is meaningful for
R = 1000 mm only (the correction is right there); elsewhere the correction is wrong for the true screen."""
import csv, glob, json, math, os, subprocess, sys
import collections
import numpy as np

KEYS = ["seed", "dist", "yaw", "fill", "sampling", "r_true", "fx", "status", "radius", "sigma", "ci_lo", "ci_hi", "z",
        "in95", "model", "noise", "det_rms", "n", "verdict", "reason", "note"]


def analyze(BIN, t, photo, out, R):
    """`curvecheck analyze` of trial t's photo into out; the row's measured columns against the truth (t.truth.json)."""
    r = subprocess.run([BIN, "analyze", photo, "--pattern", t + "_pat.json", "--camera", t + ".cameramodel", "--no-report",
                        "-o", out], capture_output=True, text=True)
    if r.returncode or not os.path.exists(out + "/result.json"):
        return dict(status="analyze_failed", note=(r.stderr.strip().splitlines() or [""])[-1][:160])
    j = json.load(open(out + "/result.json"))
    tr = {q["id"]: q["image_px"] for q in json.load(open(t + ".truth.json"))["features"]}
    e = np.array([np.subtract(q["detected_px"], tr[q["id"]]) for q in j["features"] if q["id"] in tr])
    fit = j.get("fit") or {}
    v = j.get("verification") or {}
    ci = fit.get("radius_ci95_mm") or [float("nan")] * 2
    sig = fit.get("radius_sigma_mm", float("nan"))
    rad = fit.get("radius_mm", float("nan"))
    return dict(status="ok", radius=rad, sigma=sig, ci_lo=ci[0], ci_hi=ci[1], z=(rad - R) / sig if sig else float("nan"),
                in95=int(ci[0] <= R <= ci[1]), model=fit.get("model", fit.get("chosen_model")), noise=fit.get("noise_px"),
                det_rms=float(np.sqrt((e ** 2).mean())) if len(e) else float("nan"), n=len(e), verdict=v.get("verdict"),
                reason=(v.get("reason") or "")[:100])


def reanalyze(argv):
    """The kept photos of a run analyzed again by another binary (the same photos: a before and after):
    OUTDIR/re_SUFFIX.csv, the run's columns, its analyses in OUTDIR/tSEED_SUFFIX."""
    BIN, OUT, SUF = argv[0], argv[1], argv[2]
    rows = []
    for f in sorted(glob.glob(os.path.join(OUT, "trials_*.csv"))):
        for r0 in csv.DictReader(open(f)):
            t = os.path.join(OUT, "t" + r0["seed"])
            photo = next((p for p in (t + ".png", t + ".jpg") if os.path.exists(p)), None)
            if r0["status"] not in ("ok", "analyze_failed") or photo is None: continue
            row = {k: r0[k] for k in KEYS[:7]}
            row.update(analyze(BIN, t, photo, t + "_" + SUF, float(r0["r_true"])))
            rows.append(row)
            print(row, flush=True)
    with open(os.path.join(OUT, f"re_{SUF}.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, KEYS); w.writeheader(); [w.writerow(x) for x in rows]


def run(argv):
    BIN, OUT, SEED0, NPC, SHARD, NSH = argv[0], argv[1], int(argv[2]), int(argv[3]), int(argv[4]), int(argv[5])
    opts = dict(kv.split("=", 1) for kv in argv[6:])
    HERE = os.path.dirname(os.path.abspath(__file__))
    os.makedirs(OUT, exist_ok=True)
    R_SPEC = 1000.0
    W_MM, H_MM = 1198.1153601155424, 336.96994503249635
    res = [int(v) for v in opts.get("res", "2400x1600").split("x")]
    dists = [float(v) for v in opts.get("dists", "1000,2000,3000").split(",")]
    yaws = [float(v) for v in opts.get("yaws", "0,20,40").split(",")]
    fills = [float(v) for v in opts.get("fills", "0.7,1").split(",")]
    samplings = opts.get("samplings", "jitter2,regular2,real").split(",")
    rfactors = [float(v) for v in opts.get("rfactors", "1,0.92,1.08").split(",")]

    cells = [(d, y) for d in dists for y in yaws]
    trials = []
    for ci, (d, y) in enumerate(cells):
        for k in range(NPC):
            trials.append((SEED0 + ci * 1000 + k, d, y))
    trials = trials[SHARD::NSH]
    if opts.get("only"): trials = [t for t in trials if str(t[0]) in opts["only"].split(",")]
    rows = []
    csvp = os.path.join(OUT, f"trials_{SHARD}.csv")
    for seed, d, yaw in trials:
        rng = np.random.default_rng(seed)
        fill = fills[rng.integers(len(fills))]
        samp = samplings[rng.integers(len(samplings))]
        rf = rfactors[rng.integers(len(rfactors))]
        R = R_SPEC * rf
        yr = math.radians(yaw + rng.uniform(-2, 2))
        dd = d * (1 + rng.uniform(-0.05, 0.05))
        centre = np.array([0, 0, -R])  # the true screen centre
        pos = centre + dd * np.array([math.sin(yr), 0, math.cos(yr)]) + np.array([0, rng.uniform(-30, 30), 0])
        # the pattern's viewpoint: where the camera is, in the spec's frame (centre at -R_SPEC)
        vp = pos - centre + np.array([0, 0, -R_SPEC])
        t = os.path.join(OUT, f"t{seed}")
        pat = t + "_pat"
        kind = opts.get("pattern", "checkerboard")
        grid = ["--squares", "32x9"] if kind == "checkerboard" else ["--tags", opts.get("tags", "16x4")]
        r = subprocess.run([BIN, "render", "--monitor", "default", "--viewpoint", "%.3f,%.3f,%.3f" % tuple(vp), *grid,
                            "--pattern", kind, "--method", "exact", "-o", pat + ".png"],
                           capture_output=True, text=True)
        if r.returncode:
            rows.append(dict(seed=seed, dist=d, yaw=yaw, status="render_failed")); continue
        # focal length: the screen's edges at 45% of the half width/height from the centre
        theta = (W_MM / 2) / R
        pts = [np.array([R * math.sin(s * theta), h * H_MM / 2, -R * math.cos(s * theta)]) for s in (-1, 0, 1) for h in (-1, 1)]
        f = np.array(centre) - pos; f /= np.linalg.norm(f); rt = np.cross(f, [0, 1, 0]); rt /= np.linalg.norm(rt); dn = np.cross(f, rt)
        ax = max(abs(np.dot(p - pos, rt) / np.dot(p - pos, f)) for p in pts)
        ay = max(abs(np.dot(p - pos, dn) / np.dot(p - pos, f)) for p in pts)
        fx = min(0.45 * res[0] / ax, 0.45 * res[1] / ay) * rng.uniform(0.85, 1.0)
        args = ["/usr/bin/python3", os.path.join(HERE, "trace.py"), "--pattern", pat + ".json", "--radius", str(R),
                "--width", str(res[0]), "--height", str(res[1]), "--fx", str(fx), "--pos", *map(str, pos),
                "--look", *map(str, centre), "--fill", str(fill),
                "--seed", str(seed + int(opts.get("noise_seed_offset", 0))), "-o", t]
        if samp in ("jitter1", "jitter2"):
            args += ["--spp", samp[-1]]
        elif samp in ("regular1", "regular2"):
            args += ["--spp", samp[-1], "--regular"]
        elif samp == "real":  # a camera-like photo: 4x4 rays, optics blur, noise, JPEG
            args += ["--spp", "4", "--blur", "0.6", "--noise", "0.01", "--jpeg", "92"]
        elif samp == "webcam":  # a webcam-class photo (cameras.md): 4x4 rays, blur 0.8 px, noise 2%, MJPEG-like q85
            args += ["--spp", "4", "--blur", "0.8", "--noise", "0.02", "--jpeg", "85"]
        if opts.get("k1"):
            args += ["--k1", opts["k1"], "--model-k1"]
        r = subprocess.run(args, capture_output=True, text=True)
        if r.returncode:
            rows.append(dict(seed=seed, dist=d, yaw=yaw, status="trace_failed", note=r.stderr[-200:])); continue
        photo = r.stdout.strip().splitlines()[-1]
        row = dict(seed=seed, dist=d, yaw=yaw, fill=fill, sampling=samp, r_true=R, fx=round(fx, 1))
        row.update(analyze(BIN, t, photo, t + "_out", R))
        rows.append(row)
        for p in [t + ".png", t + ".jpg"]:
            if os.path.exists(p) and opts.get("keep") != "1": os.remove(p)
        with open(csvp, "w", newline="") as fh:
            w = csv.DictWriter(fh, KEYS); w.writeheader(); [w.writerow(x) for x in rows]
        print(rows[-1], flush=True)


def summary(argv):
    rows=[]
    for f in glob.glob(argv[0]+'/trials_*.csv'): rows+=list(csv.DictReader(open(f)))
    print(len(rows),'trials')
    def wil(k,n,z=1.96):
        if n==0: return (float('nan'),)*2
        p=k/n; d=1+z*z/n; c=(p+z*z/(2*n))/d; h=z*math.sqrt(p*(1-p)/n+z*z/(4*n*n))/d; return (100*(c-h),100*(c+h))
    def rep(name, rs):
        ok=[r for r in rs if r['status']=='ok' and r['radius'] not in ('','nan')]
        k=sum(int(r['in95']) for r in ok); n=len(ok)
        zs=[float(r['z']) for r in ok if r['z'] not in ('','nan')]
        rmsz=math.sqrt(sum(z*z for z in zs)/len(zs)) if zs else float('nan')
        mz=sum(zs)/len(zs) if zs else float('nan')
        v=collections.Counter(r['verdict'] for r in ok if float(r['r_true'])==1000)
        nf=collections.Counter(r['status'] for r in rs if r['status']!='ok')
        det=sorted(float(r['det_rms']) for r in ok)
        md=det[len(det)//2] if det else float('nan')
        lo,hi=wil(k,n)
        print(f"{name:28s} n={len(rs):3d} ok={n:3d} in95 {k}/{n} [{lo:.0f},{hi:.0f}] rmsz {rmsz:.2f} mean z {mz:+.2f} det {md:.3f} verdicts(R=spec) {dict(v)} {dict(nf)}")
    rep('all',rows)
    for key in ['sampling','fill','dist','yaw','r_true']:
        for val in sorted(set(r[key] for r in rows)):
            rep(f'{key}={val}',[r for r in rows if r[key]==val])
    bad=[r for r in rows if r['status']=='ok' and r['in95']=='0']
    for r in bad: print('MISS',r['seed'],r['dist'],r['yaw'],r['fill'],r['sampling'],r['r_true'],'R',round(float(r['radius']),1),'sig',round(float(r['sigma']),2),'z',round(float(r['z']),2),r['model'],'det',round(float(r['det_rms']),3))
    for r in rows:
        if r['status']!='ok': print('FAILED',r['seed'],r['dist'],r['yaw'],r['fill'],r['sampling'],r['status'],r.get('note',''))


if __name__ == "__main__":
    if len(sys.argv) >= 8 and sys.argv[1] == "run":
        run(sys.argv[2:])
    elif len(sys.argv) == 5 and sys.argv[1] == "reanalyze":
        reanalyze(sys.argv[2:])
    elif len(sys.argv) == 3 and sys.argv[1] == "summary":
        summary(sys.argv[2:])
    else:
        raise SystemExit(__doc__)
