#!/usr/bin/env python3
"""The laser chain as a plain single-threaded OpenCV-Python script: the yardstick
`cargo bench --bench speed` times `fslcal laser` against.

Per photo: read and decode the JPEG, find the checkerboard at full resolution
(findChessboardCorners), refine its corners (cornerSubPix), solve its pose (solvePnP), and
intersect the given dot's ray with the board's plane. Then fit a line through the dots'
3D points (total least squares). No robust fit, no dot search, no gates, no report: the
steps a person would write for the same job, with the true dots given.

Install (once):  python3 -m venv ~/.venv-fslcal-bench
                 ~/.venv-fslcal-bench/bin/pip install opencv-python-headless numpy
Run:  laser_opencv.py --camera camera.yml --board 14x10@42.17 --dots dots.csv PHOTOS...
Prints one JSON line: photos used, the line, and seconds spent in decode and in the rest.
"""

import argparse
import csv
import json
import os
import sys
import time

import cv2
import numpy as np


def read_camera(path):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    k = fs.getNode("camera_matrix").mat()
    d = fs.getNode("distortion_coefficients").mat().reshape(-1)
    fs.release()
    return k, d


def read_dots(path):
    dots = {}
    with open(path, newline="") as f:
        for row in csv.reader(f):
            try:
                dots[os.path.basename(row[0])] = (float(row[1]), float(row[2]))
            except (ValueError, IndexError):
                continue  # header
    return dots


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--camera", required=True)
    ap.add_argument("--board", required=True, help="COLSxROWS@SQUAREmm (inner corners)")
    ap.add_argument("--dots", required=True)
    ap.add_argument("photos", nargs="+")
    a = ap.parse_args()
    cv2.setNumThreads(1)
    k, dist = read_camera(a.camera)
    size, square = a.board.split("@")
    cols, rows = (int(v) for v in size.split("x"))
    square_m = float(square.rstrip("m")) / 1e3
    obj = np.zeros((cols * rows, 3), np.float64)
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    dots = read_dots(a.dots)
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH + cv2.CALIB_CB_NORMALIZE_IMAGE + cv2.CALIB_CB_FAST_CHECK
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 40, 0.001)
    points, decode_s = [], 0.0
    start = time.perf_counter()
    for path in a.photos:
        t = time.perf_counter()
        img = cv2.imread(path)
        decode_s += time.perf_counter() - t
        if img is None:
            continue
        grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
        found, corners = cv2.findChessboardCorners(grey, (cols, rows), flags=flags)
        if not found:
            continue
        corners = cv2.cornerSubPix(grey, corners, (11, 11), (-1, -1), criteria)
        ok, rvec, tvec = cv2.solvePnP(obj, corners, k, dist)
        dot = dots.get(os.path.basename(path))
        if not ok or dot is None:
            continue
        r, _ = cv2.Rodrigues(rvec)
        normal, origin = r[:, 2], tvec.reshape(3)
        ray = cv2.undistortPoints(np.array([[dot]], np.float64), k, dist).reshape(2)
        ray = np.array([ray[0], ray[1], 1.0])
        points.append(ray * (normal @ origin) / (normal @ ray))
    p = np.array(points)
    centre = p.mean(axis=0)
    direction = np.linalg.svd(p - centre)[2][0]
    direction *= np.sign(direction[2])
    total = time.perf_counter() - start
    print(json.dumps({
        "photos": len(a.photos), "used": len(points), "point_m": centre.tolist(), "direction": direction.tolist(),
        "seconds": total, "decode_seconds": decode_s, "opencv": cv2.__version__,
    }))
    return 0 if len(points) >= 2 else 1


if __name__ == "__main__":
    sys.exit(main())
