#!/usr/bin/env python3
"""Images per second of the runway classifier: fleetmap vs OpenCV, same images, same run.

The pipeline is the runway paper's §7 sensing model: grey → threshold 150 → 7 dilations with
a 3×3 kernel → black fraction of five ninths. OpenCV runs it as cv2.cvtColor, cv2.threshold,
cv2.dilate(iterations=7) and cv2.countNonZero on the region views; fleetmap as
`fleetmap bench classify` (its fused bit-packed path). Decoding is excluded on both sides:
both time the pipeline on images already in memory.

Steps: fleetmap renders N synthetic 1920×1080 runway scenes and writes them as PNG; OpenCV
loads them and is timed single-threaded (cv2.setNumThreads(1)) and with one thread per core
across images; fleetmap is timed on the same PNG files; finally the fractions are checked to
agree. Usage:

    scripts/bench-vs-opencv.py [--images 16] [--seconds 3] [--bin target/release/fleetmap]
                               [--code-path best|x86-v2|portable] [--json]

Without --bin it builds `cargo build --release --bin fleetmap` and uses that binary.
Needs opencv-python-headless and numpy (make venv, or /work/venv).
"""

import argparse
import concurrent.futures
import glob
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KERNEL = np.ones((3, 3), np.uint8)
REGIONS = [(1, 1), (0, 1), (1, 0), (2, 1), (1, 2)]  # centre, top, left, bottom, right


def opencv_pipeline(bgr):
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    _, binary = cv2.threshold(gray, 150, 255, cv2.THRESH_BINARY)
    dilated = cv2.dilate(binary, KERNEL, iterations=7)
    h, w = dilated.shape
    rows = [k * h // 3 for k in range(4)]
    cols = [k * w // 3 for k in range(4)]
    out = []
    for rb, cb in REGIONS:
        region = dilated[rows[rb] : rows[rb + 1], cols[cb] : cols[cb + 1]]
        out.append((region.size - cv2.countNonZero(region)) / region.size)
    return out


def time_loop(fn, images, seconds):
    for img in images:  # warm-up
        fn(img)
    done = 0
    start = time.perf_counter()
    while True:
        for img in images:
            fn(img)
        done += len(images)
        if time.perf_counter() - start >= seconds:
            break
    return done / (time.perf_counter() - start)


def time_parallel(images, seconds, threads):
    with concurrent.futures.ThreadPoolExecutor(threads) as pool:
        list(pool.map(opencv_pipeline, images))
        done = 0
        start = time.perf_counter()
        while True:
            list(pool.map(opencv_pipeline, images))
            done += len(images)
            if time.perf_counter() - start >= seconds:
                break
    return done / (time.perf_counter() - start)


def find_binary(args):
    if args.bin:
        return args.bin
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    subprocess.run(["cargo", "build", "--release", "--bin", "fleetmap"], cwd=ROOT, check=True)
    return str(target / "release" / "fleetmap")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--images", type=int, default=16)
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--seconds", type=float, default=3.0, help="measuring time per figure")
    ap.add_argument("--bin", help="fleetmap binary (default: build target/release/fleetmap)")
    ap.add_argument("--code-path", default="best", choices=["best", "x86-v2", "portable"],
                    help="fleetmap's code path (default: the best this CPU offers)")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args()
    fleetmap = find_binary(args)

    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([fleetmap, "bench", "classify", "--width", str(args.width), "--height",
                        str(args.height), "--images", str(args.images), "--seconds", "0.01",
                        "--write-images", tmp, "--json"], check=True, capture_output=True)
        files = sorted(glob.glob(os.path.join(tmp, "bench-*.png")))
        images = [cv2.imread(f, cv2.IMREAD_COLOR) for f in files]

        cv2.setNumThreads(1)
        cv_single = time_loop(opencv_pipeline, images, args.seconds)
        threads = os.cpu_count() or 1
        cv_parallel = time_parallel(images, args.seconds, threads)

        out = subprocess.run([fleetmap, "bench", "classify", "--seconds", str(args.seconds),
                              "--code-path", args.code_path, "--json", *files],
                             check=True, capture_output=True, text=True)
        fm = json.loads(out.stdout)

        # Same answers: fleetmap's fractions equal OpenCV's on every image.
        out = subprocess.run([fleetmap, "classify", "--json", *files], capture_output=True, text=True)
        names = ["center", "top", "left", "bottom", "right"]
        for line, img in zip(out.stdout.splitlines(), images):
            got = json.loads(line)["fractions"]
            want = opencv_pipeline(img)
            for n, w in zip(names, want):
                if abs(got[n] - w) > 1e-9:
                    sys.exit(f"fractions differ on {json.loads(line)['image']}: {n} {got[n]} vs {w}")

    result = {
        "width": args.width,
        "height": args.height,
        "images": len(files),
        "opencv_version": cv2.__version__,
        "opencv_single_thread_images_per_second": cv_single,
        "opencv_parallel_images_per_second": cv_parallel,
        "fleetmap_single_thread_images_per_second": fm["images_per_second"],
        "fleetmap_parallel_images_per_second": fm["images_per_second_parallel"],
        "threads": threads,
        "fleetmap_code_path": fm.get("code_path"),
        "single_thread_ratio": fm["images_per_second"] / cv_single,
        "parallel_ratio": fm["images_per_second_parallel"] / cv_parallel,
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(f"{args.width}×{args.height}, {len(files)} images, fractions identical")
        print(f"  OpenCV {cv2.__version__} single thread : {cv_single:8.1f} images/s")
        print(f"  fleetmap single thread    : {fm['images_per_second']:8.1f} images/s"
              f"  [{fm.get('code_path')}]"
              f"  ({result['single_thread_ratio']:.2f}× OpenCV)")
        print(f"  OpenCV {threads} threads       : {cv_parallel:8.1f} images/s")
        print(f"  fleetmap {threads} threads        : {fm['images_per_second_parallel']:8.1f} images/s"
              f"  ({result['parallel_ratio']:.2f}× OpenCV)")


if __name__ == "__main__":
    main()
