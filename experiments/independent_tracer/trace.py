#!/usr/bin/python3
"""An independent ray tracer for curvecheck's photos: written apart from synth/ (another language, no shared code,
its own conventions checked only through pattern.json), so that the analysis is tested on photos it was not
tuned on (issue 16: "photos from an independent ray tracer at ordinary camera resolution").

A pinhole camera (optionally with a radial k1 the camera model may or may not be told) photographs a cylindrical
display of true radius R (the spec's arc width kept: a different R is a different sector) showing a pattern PNG
(curvecheck render's, with its pattern.json). The display has R, G, B vertical sub-pixel stripes; each emitter
covers sqrt(fill) of its stripe's width and of the pixel's height (fill: emitter area over pixel area), the rest
is the black matrix. The display's code values are decoded with its gamma 2.2. Each camera pixel is the mean of
n x n rays, jittered at random inside their cells or (--regular) at the cells' centres: point samples, no
footprint integration, so the display's structure aliases as an ideal ray tracer's does. Then optionally a
Gaussian blur, Gaussian noise, the channel mean (--mono), sRGB encoding to 8 bits, a left-right flip (--mirror)
and JPEG.
Writes OUT.png (or OUT.jpg), OUT.cameramodel (mrcal, what analyze is told: LENSMODEL_PINHOLE, or
LENSMODEL_OPENCV4 with k1 when --model-k1) and OUT.truth.json (the true radius, pose, and every pattern
feature's image position through the true lens).
usage: /usr/bin/python3 trace.py --pattern pattern.json --radius 1000 --pos X Y Z --look X Y Z -o OUT [...]
(positions in curvecheck's screen frame, mm: origin on the cylinder axis, x right, y up, screen centre (0, 0, -R))
"""
import argparse, json, math, os
import numpy as np
import cv2


def look_at(pos, target):
    f = np.asarray(target, float) - np.asarray(pos, float)
    f /= np.linalg.norm(f)
    up = np.array([0.0, 1.0, 0.0])
    r = np.cross(f, up); r /= np.linalg.norm(r)
    d = np.cross(f, r)
    return np.stack([r, d, f], axis=1)  # columns: camera x, y, z in the screen frame


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pattern", required=True)       # pattern.json (its png beside it)
    ap.add_argument("--radius", type=float, default=None)  # true radius (default: the spec's)
    ap.add_argument("--width", type=int, default=2400)
    ap.add_argument("--height", type=int, default=1600)
    ap.add_argument("--hfov", type=float, default=60.0)  # horizontal field of view, deg
    ap.add_argument("--fx", type=float, default=0.0)  # focal length in px (overrides --hfov)
    ap.add_argument("--pos", type=float, nargs=3, default=[0, 0, 0])
    ap.add_argument("--look", type=float, nargs=3, default=None)
    ap.add_argument("--k1", type=float, default=0.0)  # radial distortion of the true lens (OpenCV k1)
    ap.add_argument("--model-k1", action="store_true")  # tell analyze about k1 (LENSMODEL_OPENCV4)
    ap.add_argument("--fill", type=float, default=1.0)
    ap.add_argument("--spp", type=int, default=2)     # rays per pixel per axis
    ap.add_argument("--blur", type=float, default=0.0)  # Gaussian sigma, camera px
    ap.add_argument("--noise", type=float, default=0.0)  # sd, fraction of white
    ap.add_argument("--exposure", type=float, default=0.85)
    ap.add_argument("--mono", action="store_true")
    ap.add_argument("--jpeg", type=int, default=0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--regular", action="store_true")  # rays on a regular n x n grid (no jitter): moire
    ap.add_argument("--mirror", action="store_true")  # the photo flipped left-right (a webcam's mirror setting)
    ap.add_argument("-o", required=True)  # output stem
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)

    pj = json.load(open(a.pattern))
    mon = pj["monitor"]
    nx, ny = mon["resolution"]
    W, H = mon["width_mm"], mon["height_mm"]
    R = a.radius if a.radius else mon["radius_mm"]
    theta = (W / 2) / R  # half the arc angle: the panel's arc length is fixed, the radius is not
    png = os.path.join(os.path.dirname(os.path.abspath(a.pattern)), pj["render"]["image"])
    code = cv2.imread(png, cv2.IMREAD_COLOR)
    if code is None or code.shape[:2] != (ny, nx):
        raise SystemExit(f"{png}: not a {nx} x {ny} image (pattern.json's render.image); render the pattern again")
    img = code[:, :, ::-1].astype(np.float32) / 255.0
    lin = img ** 2.2  # the display's gamma

    look = a.look if a.look else [0, 0, -R]
    Rwc = look_at(a.pos, look)
    C = np.asarray(a.pos, float)
    fx = a.fx if a.fx > 0 else (a.width / 2) / math.tan(math.radians(a.hfov) / 2)
    fy = fx
    cx, cy = (a.width - 1) / 2, (a.height - 1) / 2

    def undistort_dir(xn, yn):
        # the true lens maps direction (x, y) to (x, y)(1 + k1 r^2); invert by fixed point
        if a.k1 == 0:
            return xn, yn
        x, y = xn.copy(), yn.copy()
        for _ in range(20):
            r2 = x * x + y * y
            x = xn / (1 + a.k1 * r2); y = yn / (1 + a.k1 * r2)
        return x, y

    sx = math.sqrt(a.fill); sy = math.sqrt(a.fill)
    out = np.zeros((a.height, a.width, 3), np.float32)
    n = a.spp
    rows_per = max(1, 2_000_000 // (a.width * n * n))
    for y0 in range(0, a.height, rows_per):
        y1 = min(a.height, y0 + rows_per)
        yy, xx = np.mgrid[y0:y1, 0:a.width].astype(np.float64)
        acc = np.zeros((y1 - y0, a.width, 3), np.float64)
        for i in range(n):
            for j in range(n):
                ox = (j + (0.5 if a.regular else rng.random(xx.shape))) / n - 0.5
                oy = (i + (0.5 if a.regular else rng.random(xx.shape))) / n - 0.5
                xn = (xx + ox - cx) / fx; yn = (yy + oy - cy) / fy
                xn, yn = undistort_dir(xn, yn)
                d = np.stack([xn, yn, np.ones_like(xn)], -1) @ Rwc.T
                # cylinder x^2 + z^2 = R^2, the far hit (the concave face)
                A = d[..., 0] ** 2 + d[..., 2] ** 2
                B = 2 * (C[0] * d[..., 0] + C[2] * d[..., 2])
                Cc = C[0] ** 2 + C[2] ** 2 - R * R
                disc = B * B - 4 * A * Cc
                ok = disc > 0
                t = (-B + np.sqrt(np.maximum(disc, 0))) / (2 * A)
                ok &= t > 0
                P = C + t[..., None] * d
                phi = np.arctan2(P[..., 0], -P[..., 2])
                u = phi / theta
                v = -P[..., 1] / (H / 2)
                ok &= (np.abs(u) <= 1) & (np.abs(v) <= 1) & (P[..., 2] < 0)
                px = (u + 1) / 2 * nx  # 0..nx edge to edge
                py = (v + 1) / 2 * ny
                ix = np.clip(np.floor(px).astype(np.int64), 0, nx - 1)
                iy = np.clip(np.floor(py).astype(np.int64), 0, ny - 1)
                fxp = px - np.floor(px); fyp = py - np.floor(py)
                sub = np.clip((fxp * 3).astype(np.int64), 0, 2)
                fs = fxp * 3 - sub  # position inside the sub-pixel
                inside = (np.abs(fs - 0.5) <= sx / 2) & (np.abs(fyp - 0.5) <= sy / 2)
                val = lin[iy, ix]  # (h, w, 3)
                sample = np.zeros_like(acc)
                for c in range(3):
                    m = ok & inside & (sub == c)
                    sample[..., c] = np.where(m, val[..., c] * 3 / (sx * sy), 0.0)
                acc += sample  # outside the active area: the black bezel
        out[y0:y1] = acc / (n * n)
    # a sub-pixel stripe carries its own channel only, and the camera's channel sees just that one (no crosstalk)
    out *= a.exposure
    if a.blur > 0:
        out = cv2.GaussianBlur(out, (0, 0), a.blur)
    if a.mono:
        out = np.repeat(out.mean(axis=2, keepdims=True), 3, axis=2)
    if a.noise > 0:
        out = out + rng.normal(0, a.noise, out.shape).astype(np.float32)
    out = np.clip(out, 0, 1)
    srgb = np.where(out <= 0.0031308, 12.92 * out, 1.055 * out ** (1 / 2.4) - 0.055)
    b = np.round(srgb * 255).astype(np.uint8)[:, :, ::-1]
    if a.mirror:
        b = b[:, ::-1]
    if a.jpeg:
        cv2.imwrite(a.o + ".jpg", b, [cv2.IMWRITE_JPEG_QUALITY, a.jpeg]); photo = a.o + ".jpg"
    else:
        cv2.imwrite(a.o + ".png", b); photo = a.o + ".png"

    # camera model for analyze (mrcal): the camera at the origin of its own frame
    if a.model_k1:
        model = "LENSMODEL_OPENCV4"; intr = [fx, fy, cx, cy, a.k1, 0, 0, 0]
    else:
        model = "LENSMODEL_PINHOLE"; intr = [fx, fy, cx, cy]
    with open(a.o + ".cameramodel", "w") as f:
        f.write("{\n  'lensmodel': '%s',\n  'intrinsics': [ %s ],\n  'extrinsics': [ 0, 0, 0, 0, 0, 0 ],\n"
                "  'imagersize': [ %d, %d ],\n}\n" % (model, ", ".join(repr(float(v)) for v in intr), a.width,
                                                     a.height))
    # truth: every feature's image position through the true lens
    feats = []
    for ft in pj["features"]:
        dx, dy = ft["display_px"]
        u = 2 * (dx + 0.5) / nx - 1; v = 2 * (dy + 0.5) / ny - 1
        P = np.array([R * math.sin(u * theta), -v * H / 2, -R * math.cos(u * theta)])
        q = Rwc.T @ (P - C)
        if q[2] <= 0:
            continue
        x, y = q[0] / q[2], q[1] / q[2]
        r2 = x * x + y * y
        x *= 1 + a.k1 * r2; y *= 1 + a.k1 * r2
        u_px = fx * x + cx
        feats.append({"id": ft["id"], "image_px": [a.width - 1 - u_px if a.mirror else u_px, fy * y + cy]})
    json.dump({"radius_mm": R, "camera_position_mm": list(C), "look_at_mm": list(look), "fill": a.fill,
               "spp": a.spp, "features": feats, "photo": photo}, open(a.o + ".truth.json", "w"), indent=1)
    print(photo)


if __name__ == "__main__":
    main()
