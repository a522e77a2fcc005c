"""The live steering panel's loop, headless: what a student's browser would receive.

    python benchmarks/live.py              # laptop size (the shipped MoGlow) and paper size, 20 s each
    python benchmarks/live.py --seconds 60
    python benchmarks/live.py --browser 60 # the panel in JupyterLab in headless Chromium (selenium)

Drives :class:`motionlab.live.Loop` (the panel's own thread and schedule) with a scripted
control sequence (walk, turn left, walk, let go; :data:`motionlab.live.SCRIPT`, repeated),
delivering each frame to a function that serialises it as the panel does, and prints per
model size and weight precision: frames/s delivered, the 50th and 99th percentile interval
between frames, the time from a control change to the first frame generated after it, and
wall and CPU milliseconds per frame. Paper size (§5.2: K = 16, 2 LSTM layers of 512,
τ = 10) is an untrained model of that shape (speed does not depend on the weights), in
float32 and, where the CPU has native bfloat16, bfloat16.

With ``--browser SECONDS`` it runs the panel as a student does instead (benchmarks/lab_browser.py:
JupyterLab in headless Chromium, keys pressed by selenium on the same script) and prints, measured
in the page, the frames received and the frames shown (after the page's playout buffer, which
shows each frame on a steady clock): frames/s and intervals of both, and each key change to the
first frame shown that the kernel generated after it saw the change.

Targets (reported, not asserted): laptop size >= 19.5 frames/s at 20 fps with a
99th-percentile interval <= 75 ms and control -> frame <= 100 ms; paper size with
bfloat16 >= 20 frames/s where the CPU has native bfloat16.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch

from motionlab import live, pretrained
from motionlab.cpu import native_bfloat16
from motionlab.models.moglow import MoGlow, MoGlowConfig


def scripted(seconds: float, fps: float):
    """The intents held at each frame of ``seconds`` of :data:`live.SCRIPT`, repeated."""
    frames = [held for span, held in live.SCRIPT for _ in range(int(round(span * fps)))]
    return [set(frames[k % len(frames)]) for k in range(int(seconds * fps))]


def drive(character: live.LiveCharacter, seconds: float) -> dict:
    """Run the panel's loop on ``character`` for ``seconds``, changing the intents on the
    script's schedule from this (the 'browser') thread, as key events would."""
    fps = character.fps
    plan = scripted(seconds, fps)
    held = {"now": set()}
    sent = []
    loop = live.Loop(lambda: character.tick(held["now"]), lambda tick: sent.append(json.dumps(
        {"p": np.round(tick.positions, 3).reshape(-1).tolist(), "c": tick.contact.astype(int).tolist()})), fps)
    loop.window = len(plan) + 10                              # keep every interval
    loop.reset_stats()
    changes = 0
    loop.start()
    began = time.perf_counter()
    for k, intents in enumerate(plan):
        due = began + k / fps + 0.5 / fps                    # key events half-way between frames
        time.sleep(max(0.0, due - time.perf_counter()))
        if intents != held["now"]:
            held["now"] = intents
            loop.changed()
            changes += 1
    time.sleep(2 / fps)
    loop.stop()
    if loop.error:
        raise RuntimeError(loop.error)
    stats = loop.stats()
    stats["control to frame p99 (ms)"] = float(np.percentile(loop.latencies, 99)) if loop.latencies else float("nan")
    stats["changes"] = changes
    return stats


def paper_model(normalizer) -> MoGlow:
    torch.manual_seed(0)
    model = MoGlow(MoGlowConfig.paper()).eval()
    model.normalizer = normalizer
    return model


KEY = {"forward": "ARROW_UP", "left": "ARROW_LEFT", "right": "ARROW_RIGHT", "back": "ARROW_DOWN"}


def browser(seconds: float) -> None:
    """The panel in JupyterLab in headless Chromium, steered by :data:`live.SCRIPT`'s keys."""
    import lab_browser
    why = lab_browser.available()
    if why:
        raise SystemExit(f"--browser: {why}")
    cells = ["from motionlab import live\npanel = live.SteeringPanel()\npanel",
             "print({k: round(float(v), 3) for k, v in panel.loop.stats().items()})"]
    with lab_browser.Lab({"live.ipynb": cells}) as lab:
        lab.run_cells(1)
        lab.wait_idle()
        d = lab.driver
        lab.start_panel()
        d.execute_script("const r = document.querySelector('.motionlab-live').motionlab; "
                         "r.arrivals.length = 0; r.shown.length = 0; r.latencies.length = 0;")
        began, held = time.perf_counter(), set()
        plan = scripted(seconds, 20.0)
        for k, intents in enumerate(plan):
            time.sleep(max(0.0, began + k / 20.0 - time.perf_counter()))
            lab.keys(down=[KEY[n] for n in intents - held], up=[KEY[n] for n in held - intents])
            held = set(intents)
        lab.keys(up=[KEY[n] for n in held])
        arrivals, shown, latencies = d.execute_script(
            "const r = document.querySelector('.motionlab-live').motionlab; return [r.arrivals, r.shown, r.latencies];")
        lab.run_cell(1)
        lab.wait_idle()
        kernel = lab.outputs(1)
    latencies = np.array(latencies)
    print(f"The panel in JupyterLab, headless Chromium, {seconds:g} s of scripted keys "
          f"({len(latencies)} key changes answered, timed to the frame shown)\n")
    print("| frames | frames/s | interval p50 / p99 / max (ms) |")
    print("|---|---|---|")
    for name, times in (("received", np.array(arrivals)), ("shown (after the playout buffer)", np.array(shown))):
        intervals = np.diff(times)
        print(f"| {name} | {1000 * (len(times) - 1) / (times[-1] - times[0]):.2f} | "
              f"{np.percentile(intervals, 50):.1f} / {np.percentile(intervals, 99):.1f} / {intervals.max():.1f} |")
    print(f"\nkey → frame shown p50 / p99 / max (ms): {np.percentile(latencies, 50):.0f} / "
          f"{np.percentile(latencies, 99):.0f} / {latencies.max():.0f}")
    print(f"\nthe kernel's loop: {kernel}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--browser", type=float, default=None, metavar="SECONDS",
                        help="run the panel in JupyterLab in headless Chromium for SECONDS instead")
    args = parser.parse_args(argv)
    if args.browser:
        return browser(args.browser)
    laptop = pretrained.load("moglow")
    rows = [("laptop (shipped)", laptop, torch.float32)]
    if native_bfloat16():
        rows.append(("laptop (shipped)", laptop, torch.bfloat16))
    paper = paper_model(laptop.normalizer)
    rows.append(("paper size (untrained)", paper, torch.float32))
    if native_bfloat16():
        rows.append(("paper size (untrained)", paper, torch.bfloat16))
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, native bfloat16: {native_bfloat16()}; "
          f"{args.seconds:g} s per row at 20 fps\n")
    print("| model | weights | frames/s delivered | interval p50 / p99 (ms) | control → frame, last / p99 (ms) "
          "| ms per frame (wall / CPU) |")
    print("|---|---|---|---|---|---|")
    for label, model, weights in rows:
        character = live.LiveCharacter(model, weights=weights)
        s = drive(character, args.seconds)
        print(f"| {label} | {str(weights).replace('torch.', '')} | {s['fps']:.2f} | {s['interval p50 (ms)']:.1f} / "
              f"{s['interval p99 (ms)']:.1f} | {s['control to frame (ms)']:.1f} / {s['control to frame p99 (ms)']:.1f} "
              f"| {s['ms per frame']:.2f} / {s['cpu ms per frame']:.2f} |")


if __name__ == "__main__":
    main()
