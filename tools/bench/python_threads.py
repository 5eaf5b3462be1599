"""Throughput of pomc.Panorama.render from Python with 1 and 2 threads (the GIL is released during
the render). Usage: python3 tools/bench/python_threads.py PANO [RUNS]; prints min/median of RUNS."""

import statistics
import sys
import threading
import time

import pomc


def throughput(pano, threads: int, frames: int) -> float:
    def work(n):
        for k in range(n):
            x = 0.05 * (k % 5)
            pano.render((x, 0.0, 0.0), (x, 1.0, 0.0), size=(960, 540))

    ts = [threading.Thread(target=work, args=(frames // threads,)) for _ in range(threads)]
    t = time.perf_counter()
    for th in ts:
        th.start()
    for th in ts:
        th.join()
    return frames / (time.perf_counter() - t)


def main():
    pano = pomc.open(sys.argv[1])
    runs = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    pano.render((0, 0, 0), (0, 1, 0), size=(64, 36))
    for threads in (1, 2):
        fps = [throughput(pano, threads, 8) for _ in range(runs)]
        print(f"{threads} thread(s): {min(fps):.2f} / {statistics.median(fps):.2f} frames/s (min / median of {runs})")


if __name__ == "__main__":
    main()
