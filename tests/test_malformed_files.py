"""Malformed motion capture files are refused clearly; legitimate variants load.

Every case takes a real CMU file (``../shared/mocap/cmu`` and ``../shared/mocap/cmu_asfamc``),
changes it in one specific way, writes it into pytest's ``tmp_path`` and calls the public
readers (``bvh.read``, ``asfamc.read_asf``/``read_amc`` and ``data.load(folder)``).

* A corrupt file must raise ``ValueError`` itself (not a subclass such as
  ``UnicodeDecodeError``, not ``IndexError`` or ``KeyError``) whose message names the file
  and, when the problem sits on one line, reads ``"<file>:<line>: ..."``.
* A legitimate variant (a byte order mark, keywords in another letter case, an uppercase
  extension, a root not called ``Hips``...) must load and give exactly the positions of the
  unmodified file.
* Files that claim or hold millions of frames must fail fast without allocating gigabytes.

A case is a function ``text -> (new text, line)``: ``line`` is the 1-based line number the
message must name, or ``None`` when the problem is not on one line. Texts keep the file's
own line endings.
"""
import gzip
import re
import time
import tracemalloc

import numpy as np
import pytest

from motionlab import asfamc, bvh, data

from conftest import CMU_DIR

ASFAMC_DIR = CMU_DIR.parent / "cmu_asfamc"        # where tests/test_asfamc.py looks (its SHARED)
TRIAL = "09_03"                                   # a short run: 128 frames, 31 joints
BVH_FILE = CMU_DIR / f"{TRIAL}.bvh"
ASF_FILE = ASFAMC_DIR / "09.asf"
AMC_FILE = ASFAMC_DIR / f"{TRIAL}.amc"

requires_asfamc = pytest.mark.skipif(
    not (ASF_FILE.is_file() and AMC_FILE.is_file()),
    reason=f"CMU ASF/AMC files 09.asf and {TRIAL}.amc not found in {ASFAMC_DIR}")
requires_bvh = pytest.mark.skipif(not BVH_FILE.is_file(), reason=f"{BVH_FILE} not found")

MAX_PEAK_BYTES = 200 * 2**20
"""Most memory a reader may allocate (tracemalloc peak) while refusing a huge file."""

HTML_PAGE = ("<!DOCTYPE html>\n<html><head><title>404 Not Found</title></head>\n"
             "<body><h1>Not Found</h1><p>The requested URL was not found.</p></body></html>\n")


# --------------------------------------------------------------------------- helpers

def original(path) -> str:
    """A real file's text, line endings kept."""
    return path.read_bytes().decode("utf-8")


def edit_line(text: str, find, edit, skip: int = 0) -> tuple[str, int]:
    """Apply ``edit`` to the line after ``skip`` matches of ``find`` (a regex); returns the
    new text and that line's 1-based number."""
    lines = text.splitlines(keepends=True)
    matches = [n for n, line in enumerate(lines) if re.search(find, line)]
    n = matches[skip]
    body = lines[n].rstrip("\r\n")
    lines[n] = edit(body) + lines[n][len(body):]
    return "".join(lines), n + 1


def replace_word(text: str, find, index: int, word: str, skip: int = 0) -> tuple[str, int]:
    """Replace whitespace-separated word ``index`` of the line ``find`` picks by ``word``."""
    def edit(line):
        words = line.split()
        words[index] = word
        return " ".join(words)
    return edit_line(text, find, edit, skip)


def cut(text: str, fraction: float) -> str:
    """The text cut short at ``fraction`` of its length (mid-line, as a broken download)."""
    return text[:int(len(text) * fraction)]


def newline(text: str) -> str:
    return "\r\n" if "\r\n" in text else "\n"


def write(folder, name: str, content) -> object:
    path = folder / name
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    return path


def assert_refused(call, path, line=None) -> str:
    """``call(path)`` raises exactly ``ValueError`` naming ``path`` (and ``line``)."""
    with pytest.raises(ValueError) as info:
        call(path)
    message = str(info.value)
    assert info.type is ValueError, f"{info.type.__name__}: {message}"
    assert str(path) in message, message
    if line is not None:
        assert f"{path}:{line}:" in message, message
    return message


def peak_bytes(call) -> tuple[int, float, BaseException | None]:
    """Run ``call()``: tracemalloc peak (bytes), seconds, and the exception it raised."""
    tracemalloc.start()
    start, raised = time.perf_counter(), None
    try:
        call()
    except Exception as err:                      # noqa: BLE001 - the caller checks it
        raised = err
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak, time.perf_counter() - start, raised


# --------------------------------------------------------------------------- BVH cases

def motion_line(text: str) -> int:
    """0-based index of the ``MOTION`` line."""
    return next(n for n, line in enumerate(text.splitlines()) if line.strip() == "MOTION")


def bvh_offset(word):
    """One value of the first non-zero joint OFFSET (LeftUpLeg)."""
    return lambda text: replace_word(text, r"OFFSET (?!0\.00000 0\.00000 0\.00000)", 2, word)


def bvh_end_site_offset(word):
    def case(text):
        end_site = next(n for n, line in enumerate(text.splitlines()) if "End Site" in line)
        return replace_word(text, r"OFFSET", 1, word, skip=sum(
            "OFFSET" in line for line in text.splitlines()[:end_site]))
    return case


def bvh_frame_value(word, frame=10, column=40):
    def case(text):
        first = motion_line(text) + 3
        return replace_word(text, r"\S", column, word, skip=first + frame)
    return case


def bvh_header(key, word):
    return lambda text: edit_line(text, rf"^{key}:", lambda line: f"{key}: {word}")


def bvh_frame_count_off_by(delta):
    def case(text):
        frames = int(re.search(r"Frames: (\d+)", text).group(1))
        return bvh_header("Frames", frames + delta)(text)
    return case


def bvh_duplicate_joint(text):
    return edit_line(text, r"JOINT RightUpLeg\b", lambda line: line.replace("RightUpLeg", "LeftUpLeg"))


def bvh_unknown_channel(text):
    return edit_line(text, r"CHANNELS 3", lambda line: line.replace("Xrotation", "Xrotatoin"), skip=3)


def bvh_frame_words(delta):
    def case(text):
        first = motion_line(text) + 3
        edit = (lambda line: " ".join(line.split()[:-1])) if delta < 0 else (lambda line: line + " 0.5")
        return edit_line(text, r"\S", edit, skip=first + 20)
    return case


def bvh_cut_mid_frame(text):
    """Cut in the middle of the last frame line."""
    lines = text.splitlines(keepends=True)
    last = lines[-1].rstrip("\r\n")
    return "".join(lines[:-1]) + last[:len(last) // 2], len(lines)


def bvh_cut_in_hierarchy(text):
    return cut(text[:text.index("MOTION")], 0.5), None


def bvh_html(text):
    return HTML_PAGE, 1


def bvh_binary_inside(text):
    """A run of random bytes (a disk error) in the middle of the motion data."""
    raw = text.encode()
    middle = len(raw) * 3 // 4
    return raw[:middle] + np.random.default_rng(1).bytes(512) + raw[middle + 512:], None


BVH_REFUSED = {
    "offset nan": bvh_offset("nan"),
    "offset inf": bvh_offset("inf"),
    "offset -inf": bvh_offset("-inf"),
    "offset 1e400": bvh_offset("1e400"),
    "end site offset nan": bvh_end_site_offset("NaN"),
    "end site offset 1e400": bvh_end_site_offset("1e400"),
    "frame value nan": bvh_frame_value("nan"),
    "frame value inf": bvh_frame_value("inf"),
    "frame value 1e400": bvh_frame_value("-1e400"),
    "frame value word": bvh_frame_value("12.x"),
    "root position nan": bvh_frame_value("nan", frame=0, column=1),
    "frame time 0": bvh_header("Frame Time", "0"),
    "frame time negative": bvh_header("Frame Time", "-0.0083333"),
    "frame time nan": bvh_header("Frame Time", "nan"),
    "frame time inf": bvh_header("Frame Time", "inf"),
    "frame time 1e-9": bvh_header("Frame Time", "1e-9"),
    "frame time in ms": bvh_header("Frame Time", "8.3333"),
    "frame time missing": bvh_header("Frame Time", ""),
    "frames negative": bvh_header("Frames", "-128"),
    "frames fraction": bvh_header("Frames", "127.5"),
    "frames 1e30": bvh_header("Frames", "1e30"),
    "frames word": bvh_header("Frames", "many"),
    "frames one more": bvh_frame_count_off_by(1),
    "frames one fewer": bvh_frame_count_off_by(-1),
    "frames overflowing": bvh_frame_count_off_by(10**40),
    "duplicate joint name": bvh_duplicate_joint,
    "unknown channel": bvh_unknown_channel,
    "frame missing a value": bvh_frame_words(-1),
    "frame with an extra value": bvh_frame_words(+1),
    "cut mid frame": bvh_cut_mid_frame,
    "cut in hierarchy": bvh_cut_in_hierarchy,
    "html page": bvh_html,
    "random bytes": lambda text: (np.random.default_rng(0).bytes(4096), None),
    "random bytes inside": bvh_binary_inside,
    "gzip compressed": lambda text: (gzip.compress(text.encode()), None),
    "utf-16": lambda text: (text.encode("utf-16"), None),
}


@requires_bvh
@pytest.mark.parametrize("case", BVH_REFUSED)
def test_malformed_bvh_is_refused_naming_file_and_line(tmp_path, case):
    content, line = BVH_REFUSED[case](original(BVH_FILE))
    path = write(tmp_path, f"{TRIAL}.bvh", content)
    assert_refused(bvh.read, path, line)
    assert_refused(data.load, path, line)                   # one file
    assert_refused(lambda p: data.load(p.parent, fps=20), path, line)      # its folder


def bvh_lowercase_keywords(text):
    keywords = (r"\b(HIERARCHY|ROOT|JOINT|OFFSET|CHANNELS|End Site|MOTION|Frames:|Frame Time:"
                r"|[XYZ](?:position|rotation))")
    return re.sub(keywords, lambda m: m.group(0).lower(), text)


def bvh_uppercase_keywords(text):
    keywords = r"\b(End Site|Frames:|Frame Time:|[XYZ](?:position|rotation))"
    return re.sub(keywords, lambda m: m.group(0).upper(), text)


def bvh_blank_lines_and_tabs(text):
    """Blank lines between frames, tabs between values, trailing spaces."""
    lines = text.splitlines()
    first = motion_line(text) + 3
    motion = [line.replace(" ", "\t") + "  " for line in lines[first:]]
    return "\n".join(lines[:first] + [m + "\n" for m in motion]) + "\n\n"


BVH_LOADS = {
    "byte order mark": lambda text: "\ufeff" + text,
    "lowercase keywords and channels": bvh_lowercase_keywords,
    "uppercase keywords and channels": bvh_uppercase_keywords,
    "crlf line endings": lambda text: text.replace("\r\n", "\n").replace("\n", "\r\n"),
    "blank lines and tabs": bvh_blank_lines_and_tabs,
    "frame time without a space": lambda text: text.replace("Frame Time: ", "Frame Time:"),
}


@requires_bvh
@pytest.mark.parametrize("case", BVH_LOADS)
def test_legitimate_bvh_variants_load_like_the_original(tmp_path, case):
    expected = bvh.read(BVH_FILE)
    path = write(tmp_path, f"{TRIAL}.bvh", BVH_LOADS[case](original(BVH_FILE)))
    clip = bvh.read(path)
    assert clip.joint_names == expected.joint_names and clip.channels == expected.channels
    assert clip.frame_time == expected.frame_time
    assert np.array_equal(clip.world_positions(True), expected.world_positions(True))
    loaded, reference = data.load(tmp_path, fps=20), data.load(BVH_FILE, fps=20)
    assert np.array_equal(loaded[0].positions, reference[0].positions)


@requires_bvh
def test_uppercase_extension_and_a_root_not_called_hips(tmp_path):
    reference = data.load(BVH_FILE, fps=20)[0]
    write(tmp_path, f"{TRIAL}.BVH", original(BVH_FILE))
    renamed = original(BVH_FILE).replace("ROOT Hips", "ROOT Root", 1)
    assert "Hips" not in renamed
    write(tmp_path, "renamed.bvh", renamed)
    upper, renamed_clip = data.load(tmp_path, fps=20)
    assert upper.name == TRIAL and renamed_clip.name == "renamed"
    assert np.array_equal(upper.positions, reference.positions)
    assert np.array_equal(renamed_clip.positions, reference.positions)


def bvh_deep(text, depth: int, frames: int = 10) -> str:
    """The file cut to ``frames`` frames, with a chain of ``depth`` nested joints without
    channels hung under the root (so the motion lines do not change)."""
    lines = text.splitlines()
    first = motion_line(text) + 3
    lines[first - 2] = f"Frames: {frames}"
    lines = lines[:first + frames]
    root_channels = next(n for n, line in enumerate(lines) if "CHANNELS" in line)
    chain = ([f"JOINT Extra{k} {{ OFFSET 0 0.1 0" for k in range(depth)]
             + ["End Site { OFFSET 0 0.1 0 }"] + ["}"] * depth)
    return "\n".join(lines[:root_channels + 1] + chain + lines[root_channels + 1:]) + "\n"


@requires_bvh
def test_a_5000_joint_deep_hierarchy_reads_and_writes_without_recursion(tmp_path):
    expected = bvh.read(BVH_FILE)
    deep = bvh.read(write(tmp_path, "deep.bvh", bvh_deep(original(BVH_FILE), 5000)))
    assert len(deep.joint_names) == 31 + 5000
    same = [deep.joint_names.index(name) for name in expected.joint_names]
    assert np.array_equal(deep.world_positions()[:, same], expected.world_positions()[:10])
    positions = deep.world_positions()
    tip = positions[0, deep.joint_names.index("Extra4999")] - positions[0, 0]
    assert np.linalg.norm(tip) == pytest.approx(500.0)          # 5000 offsets of 0.1 in line
    loaded = data.load_bvh(tmp_path / "deep.bvh")
    assert np.array_equal(loaded.positions, data.load_bvh(BVH_FILE).positions[:loaded.n_frames])
    chain = bvh.read(write(tmp_path, "chain.bvh", bvh_deep(original(BVH_FILE), 1500)))
    bvh.write(tmp_path / "again.bvh", chain)
    again = bvh.read(tmp_path / "again.bvh")
    assert again.joint_names == chain.joint_names and np.array_equal(again.parents, chain.parents)


# --------------------------------------------------------------------------- BVH memory

def bvh_huge_frame_count(text):
    return text.replace(re.search(r"Frames: \d+", text).group(0), f"Frames: {10**12}")


def bvh_empty_frame_lines(text):
    """Two million empty frame lines, as many as the header declares."""
    first = motion_line(text) + 3
    lines = text.splitlines()[:first]
    lines[first - 2] = "Frames: 2000000"
    return "\n".join(lines) + "\n" * 2_000_001


def bvh_one_value_frames(text):
    """Two million frame lines of one value each, as many as the header declares."""
    first = motion_line(text) + 3
    lines = text.splitlines()[:first]
    lines[first - 2] = "Frames: 2000000"
    return "\n".join(lines) + "\n" + "0\n" * 2_000_000


BVH_HUGE = {"frames 10**12": bvh_huge_frame_count, "2 million empty lines": bvh_empty_frame_lines,
            "2 million one-value lines": bvh_one_value_frames}


@requires_bvh
@pytest.mark.parametrize("case", BVH_HUGE)
def test_huge_bvh_fails_fast_without_allocating(tmp_path, case):
    path = write(tmp_path, f"{TRIAL}.bvh", BVH_HUGE[case](original(BVH_FILE)))
    peak, seconds, raised = peak_bytes(lambda: bvh.read(path))
    assert type(raised) is ValueError and str(path) in str(raised), raised
    assert peak < MAX_PEAK_BYTES, f"peak {peak / 2**20:.0f} MiB"
    assert seconds < 5


@requires_bvh
def test_absurd_frame_time_is_refused_before_resampling(tmp_path):
    """1e-9 s per frame would make data.load resample 128 frames to 20 fps... from 1e9 fps:
    refused by the reader, naming the line, before anything is allocated."""
    text, line = bvh_header("Frame Time", "1e-9")(original(BVH_FILE))
    path = write(tmp_path, f"{TRIAL}.bvh", text)
    peak, _, raised = peak_bytes(lambda: data.load(tmp_path, fps=20))
    assert type(raised) is ValueError and f"{path}:{line}: Frame Time" in str(raised), raised
    assert peak < MAX_PEAK_BYTES


# --------------------------------------------------------------------------- ASF cases

def bonedata_line(text: str) -> int:
    return next(n for n, line in enumerate(text.splitlines()) if line.startswith(":bonedata"))


def asf_bone_value(key, index, word, bone=1):
    """Word ``index`` of the ``key`` line of bone ``bone`` (0: lhipjoint, 1: lfemur)."""
    def case(text):
        before = sum(bool(re.match(rf"\s*{key}\b", line)) for line in text.splitlines()[:bonedata_line(text)])
        return replace_word(text, rf"^\s*{key}\b", index, word, skip=before + bone)
    return case


def asf_direction(words):
    def case(text):
        before = bonedata_line(text)
        return edit_line(text, r"^\s*direction\b", lambda line: f"     direction {words}",
                         skip=sum("direction" in line for line in text.splitlines()[:before]))
    return case


def asf_line(key, index, word):
    return lambda text: replace_word(text, rf"^\s*{key}\b", index, word)


def asf_limit(word):
    return lambda text: edit_line(text, r"limits \(", lambda line: line.replace("(-160.0", f"({word}"))


ASF_REFUSED = {
    "length nan": asf_bone_value("length", 1, "nan"),
    "length inf": asf_bone_value("length", 1, "inf"),
    "length 1e400": asf_bone_value("length", 1, "1e400"),
    "length negative": asf_bone_value("length", 1, "-7.5"),
    "direction nan": asf_direction("0.34202 nan 0"),
    "direction inf": asf_direction("inf 0 0"),
    "direction zero": asf_direction("0 0 0"),
    "direction 1e400": asf_direction("0 1e400 0"),
    "axis nan": asf_bone_value("axis", 3, "nan"),
    "limit nan": asf_limit("nan"),
    "limit 1e400": asf_limit("-1e400"),
    "root position nan": asf_line("position", 2, "nan"),
    "root orientation inf": asf_line("orientation", 1, "inf"),
    "units length 0": asf_line("length", 1, "0"),
    "units length nan": asf_line("length", 1, "nan"),
    "units mass inf": asf_line("mass", 1, "inf"),
    "cut short": lambda text: (cut(text, 0.5), None),
    "html page": lambda text: (HTML_PAGE, 1),
    "random bytes": lambda text: (np.random.default_rng(0).bytes(4096), None),
    "gzip compressed": lambda text: (gzip.compress(text.encode()), None),
}


def amc_folder(folder, asf_content, amc_content, asf_name="09.asf", amc_name=f"{TRIAL}.amc"):
    """A folder with one trial: returns the ASF and AMC paths."""
    return write(folder, asf_name, asf_content), write(folder, amc_name, amc_content)


@requires_asfamc
@pytest.mark.parametrize("case", ASF_REFUSED)
def test_malformed_asf_is_refused_naming_file_and_line(tmp_path, case):
    content, line = ASF_REFUSED[case](original(ASF_FILE))
    asf_path, _ = amc_folder(tmp_path, content, original(AMC_FILE))
    assert_refused(asfamc.read_asf, asf_path, line)
    assert_refused(lambda p: data.load(p.parent, fps=20), asf_path, line)


def asf_uppercase_sections(text):
    return re.sub(r"(?m)^:\w+", lambda m: m.group(0).upper(), text)


def asf_uppercase_keywords(text):
    keywords = (r"(?m)^(\s*)(begin|end|id|name|direction|length|axis|dof|limits|mass|angle|order"
                r"|position|orientation)\b")
    return re.sub(keywords, lambda m: m.group(1) + m.group(2).upper(), asf_uppercase_sections(text))


ASF_LOADS = {
    "byte order mark": lambda text: "\ufeff" + text,
    "uppercase section names": asf_uppercase_sections,
    "uppercase keywords": asf_uppercase_keywords,
    "crlf line endings": lambda text: text.replace("\r\n", "\n").replace("\n", "\r\n"),
    "limits -inf inf": lambda text: text.replace("(-160.0 20.0)", "(-inf inf)", 1),
}


@requires_asfamc
@pytest.mark.parametrize("case", ASF_LOADS)
def test_legitimate_asf_variants_load_like_the_original(tmp_path, case):
    asf = asfamc.read_asf(ASF_FILE)
    expected = asfamc.world_positions(asf, asfamc.read_amc(AMC_FILE, asf))[0]
    asf_path, amc_path = amc_folder(tmp_path, ASF_LOADS[case](original(ASF_FILE)), original(AMC_FILE))
    variant = asfamc.read_asf(asf_path)
    assert variant.bone_names == asf.bone_names and variant.children == asf.children
    assert np.array_equal(asfamc.world_positions(variant, asfamc.read_amc(amc_path, variant))[0], expected)


# --------------------------------------------------------------------------- AMC cases

def amc_frame_line(frame: int):
    """A regex for the line holding frame number ``frame``."""
    return rf"^{frame}\s*$"


def amc_bone_value(bone, index, word, frame=10):
    def case(text):
        start = edit_line(text, amc_frame_line(frame), lambda line: line)[1]
        skip = sum(bool(re.match(rf"{bone}\b", line)) for line in text.splitlines()[:start])
        return replace_word(text, rf"^{bone}\b", index, word, skip=skip)
    return case


def amc_frame_number(frame, word):
    return lambda text: edit_line(text, amc_frame_line(frame), lambda line: word)


def amc_edit_bone_line(bone, edit, frame=10):
    def case(text):
        start = edit_line(text, amc_frame_line(frame), lambda line: line)[1]
        skip = sum(bool(re.match(rf"{bone}\b", line)) for line in text.splitlines()[:start])
        return edit_line(text, rf"^{bone}\b", edit, skip=skip)
    return case


def amc_header_only(text):
    return "".join(text.splitlines(keepends=True)[:3]), 3


def amc_html_after_first_line(text):
    first = text.splitlines(keepends=True)[0]
    return first + HTML_PAGE, 2


def amc_bone_twice(text):
    text, line = amc_edit_bone_line("ltibia", lambda l: l + newline(text) + l)(text)
    return text, line + 1


AMC_REFUSED = {
    "value nan": amc_bone_value("lfemur", 2, "nan"),
    "value inf": amc_bone_value("lfemur", 1, "inf"),
    "value 1e400": amc_bone_value("root", 3, "1e400"),
    "value word": amc_bone_value("rtibia", 1, "bent"),
    "empty file": lambda text: ("", None),
    "only blank lines": lambda text: ("\n" * 10, None),
    "header only": amc_header_only,
    "frame number overflowing": amc_frame_number(50, "9" * 30),
    "frame number skipped": amc_frame_number(50, "51"),
    "frame number repeated": amc_frame_number(50, "49"),
    "bone not in the asf": amc_edit_bone_line("lfemur", lambda l: l.replace("lfemur", "lthigh")),
    "bone given twice": amc_bone_twice,
    "bone missing a value": amc_edit_bone_line("lfemur", lambda l: " ".join(l.split()[:-1])),
    "bone with an extra value": amc_edit_bone_line("lfemur", lambda l: l + " 1.5"),
    "html after the first line": amc_html_after_first_line,
    "html after the header": lambda text: ("".join(text.splitlines(keepends=True)[:3]) + HTML_PAGE, 4),
    "random bytes": lambda text: (np.random.default_rng(0).bytes(4096), None),
    "gzip compressed": lambda text: (gzip.compress(text.encode()), None),
}


@requires_asfamc
@pytest.mark.parametrize("case", AMC_REFUSED)
def test_malformed_amc_is_refused_naming_file_and_line(tmp_path, case):
    content, line = AMC_REFUSED[case](original(AMC_FILE))
    asf_path, amc_path = amc_folder(tmp_path, original(ASF_FILE), content)
    asf = asfamc.read_asf(asf_path)
    assert_refused(lambda p: asfamc.read_amc(p, asf), amc_path, line)
    assert_refused(lambda p: data.load(p.parent, fps=20), amc_path, line)


def last_frame_start(text: str) -> int:
    """Character index where the last frame's number line starts."""
    return [m.start() for m in re.finditer(r"(?m)^\d+\s*$", text)][-1]


def amc_cut_in_last_frame(fraction):
    def case(text):
        start = last_frame_start(text)
        return text[:start + int((len(text) - start) * fraction)]
    return case


AMC_CUT = {
    "after the frame number": lambda text: text[:text.index("\n", last_frame_start(text)) + 1],
    "between bone lines": lambda text: text[:text.rindex("\n", 0, last_frame_start(text) + 400) + 1],
    "mid bone line": amc_cut_in_last_frame(0.5),
    "before the last value": lambda text: text.rstrip().rsplit(" ", 1)[0],
}


@requires_asfamc
@pytest.mark.parametrize("case", AMC_CUT)
def test_amc_cut_short_drops_its_last_frame_with_a_warning(tmp_path, case):
    """Never rest-posed or zero-filled: the partial frame goes, with a warning naming the file."""
    asf = asfamc.read_asf(ASF_FILE)
    expected = asfamc.world_positions(asf, asfamc.read_amc(AMC_FILE, asf))[0]
    _, amc_path = amc_folder(tmp_path, original(ASF_FILE), AMC_CUT[case](original(AMC_FILE)))
    with pytest.warns(UserWarning, match=re.escape(str(amc_path))):
        amc = asfamc.read_amc(amc_path, asf)
    assert amc.n_frames == len(expected) - 1
    assert np.array_equal(asfamc.world_positions(asf, amc)[0], expected[:-1])
    with pytest.warns(UserWarning, match="cut short"):
        assert data.load(tmp_path, fps=120)[0].n_frames == len(expected) - 1


@requires_asfamc
def test_amc_cut_inside_its_only_frame_is_refused(tmp_path):
    text = original(AMC_FILE)
    first_frame_cut = text[:text.index("lfemur")] + "lfemur 1"      # frame 1 ends mid line
    asf_path, amc_path = amc_folder(tmp_path, original(ASF_FILE), first_frame_cut)
    asf = asfamc.read_asf(asf_path)
    with pytest.warns(UserWarning, match="cut short"):
        assert_refused(lambda p: asfamc.read_amc(p, asf), amc_path)


AMC_LOADS = {
    "byte order mark": lambda text: "\ufeff" + text,
    "lowercase keywords": lambda text: text.replace(":FULLY-SPECIFIED", ":fully-specified")
                                           .replace(":DEGREES", ":degrees"),
    "crlf line endings": lambda text: text.replace("\r\n", "\n").replace("\n", "\r\n"),
}


@requires_asfamc
@pytest.mark.parametrize("case", AMC_LOADS)
def test_legitimate_amc_variants_load_like_the_original(tmp_path, case):
    asf = asfamc.read_asf(ASF_FILE)
    expected = asfamc.world_positions(asf, asfamc.read_amc(AMC_FILE, asf))[0]
    _, amc_path = amc_folder(tmp_path, original(ASF_FILE), AMC_LOADS[case](original(AMC_FILE)))
    assert np.array_equal(asfamc.world_positions(asf, asfamc.read_amc(amc_path, asf))[0], expected)


@requires_asfamc
def test_uppercase_asf_and_amc_extensions_load_from_a_folder(tmp_path):
    reference = data.load(AMC_FILE, fps=20)[0]
    amc_folder(tmp_path, original(ASF_FILE), original(AMC_FILE), "09.ASF", f"{TRIAL}.AMC")
    clips = data.load(tmp_path, fps=20)
    assert [c.name for c in clips] == [TRIAL]
    assert np.array_equal(clips[0].positions, reference.positions)


@requires_asfamc
def test_amc_of_empty_lines_fails_fast_without_allocating(tmp_path):
    header = "".join(original(AMC_FILE).splitlines(keepends=True)[:3])
    asf_path, amc_path = amc_folder(tmp_path, original(ASF_FILE), header + "\n" * 2_000_000)
    asf = asfamc.read_asf(asf_path)
    peak, seconds, raised = peak_bytes(lambda: asfamc.read_amc(amc_path, asf))
    assert type(raised) is ValueError and f"{amc_path}:" in str(raised), raised
    assert peak < MAX_PEAK_BYTES and seconds < 5
