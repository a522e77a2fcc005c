"""Settings for running the notebooks as tests (nbval).

After a cell finishes, nbval waits for each of the cell's output messages for at most
5 seconds, a value hard-coded in nbval 0.11 (nbval issues #136 and #231; its
``--nbval-cell-timeout`` does not cover it). A cell that drew many progress-bar updates
can take longer than that to deliver them on a busy 2-core machine, and the notebook
then fails with "Timeout of 5 seconds exceeded waiting for output" although it ran
correctly. We give it a minute.
"""
OUTPUT_TIMEOUT_S = 60


def pytest_collection_modifyitems(items):
    from nbval.plugin import IPyNbCell
    for item in items:
        if isinstance(item, IPyNbCell):
            item.output_timeout = OUTPUT_TIMEOUT_S
