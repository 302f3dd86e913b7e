"""fleetmap's vision pipeline against OpenCV, pixel for pixel.

The runway sensing model (runway paper §7) is grey → threshold 150 → 7 dilations with a
3×3 kernel → black fractions of the centre/top/left/bottom/right ninths; the bandit paper's
measurement (§V) is the share of pixels inside an HSV box. Here OpenCV (cv2) computes both
on the same files that `fleetmap classify --json --debug-dir` reads, and the fractions
(to 1e-9) and every intermediate image (exactly) must agree.

Run: FLEETMAP_BIN=target/debug/fleetmap python -m pytest -q tests/py/test_vision_opencv.py
"""

import json
import os
import resource
import struct
import subprocess
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
ASSETS = ROOT / "assets" / "images"
BIN = os.environ.get("FLEETMAP_BIN", str(ROOT / "target" / "debug" / "fleetmap"))

GREEN_LOWER = (35, 60, 40)
GREEN_UPPER = (85, 255, 255)
KERNEL = np.ones((3, 3), np.uint8)
REGIONS = {"center": (1, 1), "top": (0, 1), "left": (1, 0), "bottom": (2, 1), "right": (1, 2)}


def opencv_pipeline(path, intensity=150, dilations=7):
    """The paper's pipeline in OpenCV: returns grey, binary, dilated, fractions."""
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    assert bgr is not None, path
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    _, binary = cv2.threshold(gray, intensity, 255, cv2.THRESH_BINARY)
    dilated = cv2.dilate(binary, KERNEL, iterations=dilations)
    h, w = dilated.shape
    rows = [k * h // 3 for k in range(4)]
    cols = [k * w // 3 for k in range(4)]
    fractions = {}
    for name, (rb, cb) in REGIONS.items():
        region = dilated[rows[rb] : rows[rb + 1], cols[cb] : cols[cb + 1]]
        black = region.size - cv2.countNonZero(region)
        fractions[name] = black / region.size
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    green = cv2.inRange(hsv, np.array(GREEN_LOWER, np.uint8), np.array(GREEN_UPPER, np.uint8))
    green_fraction = cv2.countNonZero(green) / green.size
    return gray, binary, dilated, fractions, green, green_fraction


def run_classify(paths, debug_dir, *extra, limit_memory=None):
    def limit():
        if limit_memory:
            resource.setrlimit(resource.RLIMIT_AS, (limit_memory, limit_memory))

    cmd = [BIN, "classify", "--json", "--green", "--debug-dir", str(debug_dir), *extra]
    cmd += [str(p) for p in paths]
    out = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=limit, timeout=600)
    lines = [json.loads(line) for line in out.stdout.splitlines()]
    assert len(lines) == len(paths), out.stderr
    return out.returncode, lines


def debug_image(debug_dir, index, path, step):
    f = Path(debug_dir) / f"{index}-{Path(path).stem}.{step}.png"
    img = cv2.imread(str(f), cv2.IMREAD_UNCHANGED)
    assert img is not None, f
    return img


def compare(paths, tmp_path, *extra, intensity=150, dilations=7):
    debug = tmp_path / "debug"
    code, lines = run_classify(paths, debug, *extra)
    assert code == 0, lines
    for i, (path, line) in enumerate(zip(paths, lines)):
        assert line["image"] == str(path)
        gray, binary, dilated, fractions, green, green_fraction = opencv_pipeline(
            path, intensity, dilations
        )
        assert (line["height"], line["width"]) == gray.shape
        np.testing.assert_array_equal(debug_image(debug, i, path, "gray"), gray, f"{path} grey")
        np.testing.assert_array_equal(debug_image(debug, i, path, "binary"), binary, f"{path} binary")
        np.testing.assert_array_equal(debug_image(debug, i, path, "dilated"), dilated, f"{path} dilated")
        np.testing.assert_array_equal(debug_image(debug, i, path, "green"), green, f"{path} green")
        for name, value in fractions.items():
            assert abs(line["fractions"][name] - value) <= 1e-9, (path, name)
        assert abs(line["green"]["fraction"] - green_fraction) <= 1e-9, path
    return lines


def sample_images():
    files = sorted(ASSETS.glob("*.png"))
    assert len(files) >= 10, "sample images missing"
    return files


def test_sample_images_match_opencv(tmp_path):
    ok = [p for p in sample_images() if min(cv2.imread(str(p)).shape[:2]) >= 3]
    lines = compare(ok, tmp_path)
    # The labels follow from the fractions with the default threshold 0.5 (heading 0:
    # top = north, left = west, bottom = south, right = east).
    for line in lines:
        f, lab = line["fractions"], line["labels"]
        for region, direction in [("center", "center"), ("top", "north"), ("left", "west"),
                                  ("bottom", "south"), ("right", "east")]:
            assert lab[direction] == (f[region] >= 0.5)


def test_golden_file_agrees_with_opencv():
    golden = json.loads((ASSETS / "golden.json").read_text())
    for name, g in golden.items():
        _, _, _, fractions, _, green_fraction = opencv_pipeline(ASSETS / f"{name}.png")
        for region, value in fractions.items():
            assert abs(g["fractions"][region] - value) <= 1e-9, (name, region)
        assert abs(g["green_fraction"] - green_fraction) <= 1e-9, name


def random_images(tmp_path):
    """Random images of awkward sizes, 8-bit RGB, RGBA, grey and 16-bit PNGs."""
    rng = np.random.default_rng(20240611)
    paths = []
    sizes = [(3, 3), (5, 4), (11, 14), (14, 15), (15, 16), (31, 17), (63, 40), (64, 64),
             (65, 33), (100, 129), (127, 200), (257, 130), (480, 480)]
    for i, (w, h) in enumerate(sizes):
        # Sparse bright pixels so the dilation matters, plus values near the threshold.
        base = rng.integers(0, 200, (h, w, 3), dtype=np.uint8)
        bright = rng.random((h, w)) < rng.uniform(0.0, 0.05)
        base[bright] = rng.integers(150, 256, (int(bright.sum()), 3), dtype=np.uint8)
        p = tmp_path / f"rand-{i}-{w}x{h}.png"
        cv2.imwrite(str(p), base)
        paths.append(p)
    noise = rng.integers(0, 256, (97, 101, 3), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "noise.png"), noise)
    paths.append(tmp_path / "noise.png")
    rgba = rng.integers(0, 256, (40, 50, 4), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "rgba.png"), rgba)
    paths.append(tmp_path / "rgba.png")
    grey = rng.integers(0, 256, (45, 38), dtype=np.uint8)
    cv2.imwrite(str(tmp_path / "grey.png"), grey)
    paths.append(tmp_path / "grey.png")
    deep = rng.integers(0, 65536, (33, 70, 3), dtype=np.uint16)
    cv2.imwrite(str(tmp_path / "rgb16.png"), deep)
    paths.append(tmp_path / "rgb16.png")
    deep_grey = rng.integers(0, 65536, (20, 21), dtype=np.uint16)
    cv2.imwrite(str(tmp_path / "grey16.png"), deep_grey)
    paths.append(tmp_path / "grey16.png")
    return paths


def test_random_images_match_opencv(tmp_path):
    compare(random_images(tmp_path), tmp_path)


@pytest.mark.parametrize("intensity,dilations", [(0, 1), (100, 3), (200, 0), (254, 12)])
def test_other_parameters_match_opencv(tmp_path, intensity, dilations):
    paths = random_images(tmp_path)[:6] + sample_images()[:2]
    compare(paths, tmp_path, "--intensity", str(intensity), "--dilations", str(dilations),
            intensity=intensity, dilations=dilations)


def test_every_colour_matches_opencv(tmp_path):
    """All 2^24 colours once: grey levels and the HSV box are exact for every colour."""
    a = np.arange(1 << 24, dtype=np.uint32)
    rgb = np.stack([(a >> 16) & 255, (a >> 8) & 255, a & 255], -1).astype(np.uint8)
    bgr = rgb.reshape(4096, 4096, 3)[..., ::-1].copy()
    path = tmp_path / "all-colours.png"
    cv2.imwrite(str(path), bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    debug = tmp_path / "debug"
    code, lines = run_classify([path], debug, "--dilations", "0")
    assert code == 0, lines
    gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
    np.testing.assert_array_equal(debug_image(debug, 0, path, "gray"), gray)
    _, binary = cv2.threshold(gray, 150, 255, cv2.THRESH_BINARY)
    np.testing.assert_array_equal(debug_image(debug, 0, path, "binary"), binary)
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    green = cv2.inRange(hsv, np.array(GREEN_LOWER, np.uint8), np.array(GREEN_UPPER, np.uint8))
    np.testing.assert_array_equal(debug_image(debug, 0, path, "green"), green)


def png_with_header(width, height):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\0" * 16)) + chunk(b"IEND", b""))


def jpeg_with_header(width, height):
    out = b"\xff\xd8" + b"\xff\xdb\x00\x43\x00" + bytes([1] * 64)
    out += b"\xff\xc0\x00\x0b\x08" + struct.pack(">HH", height, width) + b"\x01\x01\x11\x00"
    out += b"\xff\xc4\x00\x14\x00\x01" + bytes(15) + b"\x00"
    out += b"\xff\xda\x00\x08\x01\x01\x00\x00\x3f\x00\xff\xd9"
    return out


def test_hostile_images_do_not_stop_the_run(tmp_path):
    good = ASSETS / "runway-centre-markings.png"
    data = good.read_bytes()
    bad = {
        "empty.png": b"",
        "truncated.png": data[: len(data) // 2],
        "corrupt.png": data[:100] + bytes(b ^ 0x5A for b in data[100:4000]) + data[4000:],
        "huge.png": png_with_header(30000, 30000),
        "huge.jpg": jpeg_with_header(30000, 30000),
        "bitmap.bmp": b"BM" + bytes(60),
        "notes.png": b"this is not an image",
    }
    paths = [good]
    for name, content in bad.items():
        (tmp_path / name).write_bytes(content)
        paths.append(tmp_path / name)
    paths.append(tmp_path / "missing.png")
    paths.append(ASSETS / "grass.png")
    # 1 GiB of address space: decoding a 30000×30000 image (2.7 GB) would fail loudly;
    # checking the header first never tries.
    code, lines = run_classify(paths, tmp_path / "debug", limit_memory=1 << 30)
    assert code == 1
    assert "fractions" in lines[0] and "fractions" in lines[-1]
    for line in lines[1:-1]:
        assert set(line) == {"image", "error"}, line
        assert line["error"]
    by_name = {Path(line["image"]).name: line for line in lines}
    assert "30000×30000" in by_name["huge.png"]["error"]
    assert "30000×30000" in by_name["huge.jpg"]["error"]
    assert "unsupported" in by_name["bitmap.bmp"]["error"]
    # The good images are still exact.
    _, _, _, fractions, _, _ = opencv_pipeline(good)
    for name, value in fractions.items():
        assert abs(lines[0]["fractions"][name] - value) <= 1e-9
