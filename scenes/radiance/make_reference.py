#!/usr/bin/env python3
"""Reference luminances for plastic_sphere.rad and metal_sphere.rad from RADIANCE 6 itself.

How the numbers in tests/render/radiance_import.rs were obtained (run from anywhere):

    python3 -m venv /tmp/radvenv && /tmp/radvenv/bin/pip install pyradiance==1.3.1 numpy
    /tmp/radvenv/bin/python scenes/radiance/make_reference.py > scenes/radiance/reference.json

pyradiance 1.3.1's wheel ships the RADIANCE 6.0a binaries (oconv, rtrace); this
script only runs those two, with RAYPATH pointing at the wheel's lib folder.

The measurement is lightbooth's radiometer: the mean radiance over the field
of FIELD_DEG (full angle) around the direction from RADIOMETER to each target.
Here that mean is taken over N_RAYS directions stratified uniformly in solid
angle inside that cone (a sqrt(N) × sqrt(N) grid in (1 - cos θ, φ), one
jittered point per cell), each traced by rtrace with the high-accuracy
settings below: no ambient cache (-aa 0, so every indirect value is a fresh
Monte Carlo estimate), 8 bounces with Russian roulette below weight 1e-5
(-lr -16 -lw 1e-5: unbiased), 1024 ambient samples at the first bounce,
16 samples of each glossy lobe (-ss 16 -st 0), every shadow ray tested
(-dc 1 -dt 0) and the light source fully jittered (-dj 1). The jitter matters:
rtrace samples a sphere source at one point per ray (-ds does not subdivide
it; tried 0.2 to 0.005, no change), so with -dj 0 the glossy highlight is the
lobe at the source's centre times its solid angle, 6 % above the integral over
the source for this roughness (218 vs 205 cd/m² at ball_highlight, -ab 0);
-dj 1 draws the point uniformly over the source's disc, an unbiased estimate
of that integral (partial jitter, -dj 0.7, lies in between: 213).
Even -dj 1 is not uniform over the source: nextssamp() in RADIANCE's
src/rt/srcsamp.c jitters a point in the sphere's volume (a cube trimmed to a
ball), whose projection crowds the disc's centre, so a highlight narrower
than the lamp's image still comes out high (203 vs lightbooth's 197.5). The
highlight targets (GLOW_TARGETS) are therefore taken from a second run in
which the lamp is `glow` with maxrad 0 instead of `light`: RADIANCE then does
not sample it as a source at all, and it is found only by the glossy lobe's
own sampling rays (-ss 64): unbiased, if noisier. The light itself is the
same (a glow of the same RGB has the same radiance). Luminance is RADIANCE's
179 lm/W × (0.265074 R + 0.670115 G + 0.064811 B) (RADIANCE's CIE_rf/gf/bf,
its primaries with an equal-energy white). The standard error comes from the
spread of the per-ray luminances (conservative: it includes the variation of
the true radiance across the field). Convergence: the same run with the
CHECK settings (a quarter of the ambient samples, a different direction
jitter) must agree within 3 combined standard errors; the script prints both.
"""

import json
import math
import os
import random
import subprocess
import sys
import tempfile

import pyradiance

HERE = os.path.dirname(os.path.abspath(__file__))
BIN = os.path.join(os.path.dirname(pyradiance.__file__), "bin")
LIB = os.path.join(os.path.dirname(pyradiance.__file__), "lib")

RADIOMETER = (2.4, -1.6, 1.6)
FIELD_DEG = 1.0
N_RAYS = 4096

SETTINGS = "-ab 8 -ad 1024 -as 0 -aa 0 -lw 1e-5 -lr -16 -ss 16 -st 0 -ds 0.02 -dj 1 -dc 1 -dt 0".split()
CHECK = "-ab 8 -ad 256 -as 0 -aa 0 -lw 1e-5 -lr -16 -ss 16 -st 0 -ds 0.02 -dj 1 -dc 1 -dt 0".split()

GLOW_TARGETS = ["ball_highlight"]
GLOW_SETTINGS = [("-ss" if a == "-ss" else a) for a in SETTINGS]
GLOW_SETTINGS[GLOW_SETTINGS.index("-ss") + 1] = "64"
GLOW_CHECK = [a for a in CHECK]
GLOW_CHECK[GLOW_CHECK.index("-ss") + 1] = "64"

CIE = (0.265074126, 0.670114631, 0.064811243)
EFFICACY = 179.0


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def add(a, b):
    return tuple(x + y for x, y in zip(a, b))


def mul(a, k):
    return tuple(x * k for x in a)


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def norm(a):
    return mul(a, 1.0 / math.sqrt(dot(a, a)))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


BALL_C, BALL_R = (0.0, 0.0, 0.5), 0.5
LAMP = (0.0, 0.0, 2.0)


def on_ball(n):
    return add(BALL_C, mul(norm(n), BALL_R))


def highlight():
    """The point of the ball whose mirror direction takes the lamp's centre to the radiometer."""
    n = norm(sub(RADIOMETER, BALL_C))
    for _ in range(200):
        p = on_ball(n)
        n = norm(add(norm(sub(LAMP, p)), norm(sub(RADIOMETER, p))))
    return on_ball(n)


TARGETS = {
    # Floor in the open, lit directly: the glossy ball adds little.
    "floor_open": (1.2, 0.6, 0.0),
    # Floor in the ball's umbra: only light the ball and floor reflect.
    "floor_shadow": (0.45, -0.32, 0.0),
    # The ball where the lamp's mirror image is: the highlight dominates.
    "ball_highlight": highlight(),
    # The ball's lit side, far from the highlight: mostly diffuse.
    "ball_diffuse": on_ball((0.2, -0.9, 0.5)),
    # The ball's underside facing the radiometer: lit by the floor only.
    "ball_underside": on_ball((0.8, -0.55, -0.35)),
}


def directions(target, n, seed):
    rng = random.Random(seed)
    axis = norm(sub(target, RADIOMETER))
    helper = (1.0, 0.0, 0.0) if abs(axis[0]) < 0.9 else (0.0, 1.0, 0.0)
    u = norm(cross(axis, helper))
    v = cross(axis, u)
    cos_max = math.cos(math.radians(FIELD_DEG / 2))
    side = int(math.isqrt(n))
    out = []
    for i in range(side):
        for j in range(side):
            a = (i + rng.random()) / side
            b = (j + rng.random()) / side
            cos_t = 1.0 - a * (1.0 - cos_max)
            sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
            phi = 2 * math.pi * b
            d = add(add(mul(u, sin_t * math.cos(phi)), mul(v, sin_t * math.sin(phi))), mul(axis, cos_t))
            out.append(d)
    return out


def measure(octree, target, settings, seed):
    rays = "".join(
        "%.9f %.9f %.9f %.12f %.12f %.12f\n" % (*RADIOMETER, *d) for d in directions(target, N_RAYS, seed)
    )
    env = dict(os.environ, RAYPATH="." + os.pathsep + LIB)
    out = subprocess.run(
        [os.path.join(BIN, "rtrace"), "-h", "-ov", *settings, octree],
        input=rays, capture_output=True, text=True, env=env, check=True,
    ).stdout
    rgb = [tuple(float(x) for x in line.split()) for line in out.strip().splitlines()]
    lum = [EFFICACY * dot(c, CIE) for c in rgb]
    n = len(lum)
    mean = sum(lum) / n
    se = math.sqrt(sum((y - mean) ** 2 for y in lum) / (n - 1) / n)
    mean_rgb = [sum(c[k] for c in rgb) / n for k in range(3)]
    return {"rgb_w_sr_m2": mean_rgb, "luminance_cd_m2": mean, "se_cd_m2": se}


def main():
    result = {
        "radiance_version": subprocess.run(
            [os.path.join(BIN, "rtrace"), "-version"], capture_output=True, text=True
        ).stdout.strip(),
        "radiometer": RADIOMETER,
        "field_deg": FIELD_DEG,
        "rays_per_target": N_RAYS,
        "settings": " ".join(SETTINGS),
        "check_settings": " ".join(CHECK),
        "glow_targets": GLOW_TARGETS,
        "glow_settings": " ".join(GLOW_SETTINGS),
        "glow_check_settings": " ".join(GLOW_CHECK),
        "targets": {k: list(v) for k, v in TARGETS.items()},
        "scenes": {},
    }
    ok = True
    for scene in ["plastic_sphere", "metal_sphere"]:
        with tempfile.TemporaryDirectory() as tmp:
            octree = os.path.join(tmp, scene + ".oct")
            with open(octree, "wb") as f:
                subprocess.run(
                    [os.path.join(BIN, "oconv"), os.path.join(HERE, scene + ".rad")], stdout=f, check=True
                )
            text = open(os.path.join(HERE, scene + ".rad")).read()
            glow_text = text.replace("void light lamp_white\n0\n0\n3 100 95 80", "void glow lamp_white\n0\n0\n4 100 95 80 0")
            assert glow_text != text
            glow_octree = os.path.join(tmp, scene + "_glow.oct")
            with open(glow_octree, "wb") as f:
                subprocess.run([os.path.join(BIN, "oconv"), "-"], input=glow_text.encode(), stdout=f, check=True)
            values = {}
            for name, target in TARGETS.items():
                glow = name in GLOW_TARGETS
                oct_, main_s, check_s = (glow_octree, GLOW_SETTINGS, GLOW_CHECK) if glow else (octree, SETTINGS, CHECK)
                main_run = measure(oct_, target, main_s, seed=1)
                check_run = measure(oct_, target, check_s, seed=2)
                main_run["lamp"] = "glow 0 (sampled by the lobe)" if glow else "light (sampled as a source)"
                diff = main_run["luminance_cd_m2"] - check_run["luminance_cd_m2"]
                combined = math.hypot(main_run["se_cd_m2"], check_run["se_cd_m2"])
                main_run["check_luminance_cd_m2"] = check_run["luminance_cd_m2"]
                main_run["check_se_cd_m2"] = check_run["se_cd_m2"]
                converged = abs(diff) <= 3 * combined
                ok &= converged
                print(
                    f"{scene} {name}: {main_run['luminance_cd_m2']:.4f} ± {main_run['se_cd_m2']:.4f} cd/m² "
                    f"(check {check_run['luminance_cd_m2']:.4f} ± {check_run['se_cd_m2']:.4f}; "
                    f"{'agree' if converged else 'DISAGREE'})",
                    file=sys.stderr,
                )
                values[name] = main_run
            result["scenes"][scene] = values
    json.dump(result, sys.stdout, indent=2)
    print()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
