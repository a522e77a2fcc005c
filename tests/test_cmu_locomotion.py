"""The CMU locomotion list is data, read with named errors."""
import pytest

from motionlab import cmu_locomotion


def test_the_shipped_list_reads_as_685_distinct_trials():
    trials = cmu_locomotion.LOCOMOTION_FULL
    assert len(trials) == 685 == len({trial for trial, _ in trials})
    assert trials[0] == ("02_01", "walk") and all(description for _, description in trials)


BAD = {
    "no header": ("02_01\twalk\n", "line 1"),
    "no tab": ("trial\tdescription\n02_01 walk\n", "line 2"),
    "not a trial": ("trial\tdescription\n02_01\twalk\nimport os\tx\n", "line 3"),
    "empty description": ("trial\tdescription\n02_01\t \n", "line 2"),
    "twice": ("trial\tdescription\n02_01\twalk\n02_01\trun\n", "line 3: trial 02_01 is listed twice"),
}


@pytest.mark.parametrize("text, where", BAD.values(), ids=BAD.keys())
def test_a_malformed_list_names_the_file_and_line(tmp_path, text, where):
    path = tmp_path / "trials.tsv"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"trials.tsv, {where}"):
        cmu_locomotion.read_trials(path)
