"""Drive JupyterLab (or Notebook 7: ``app="notebook"``) in headless Chromium (selenium): what benchmarks/live.py --browser and
tests/test_live_browser.py use to run the live panel as a student would.

    with Lab({"live.ipynb": ["from motionlab import live", "panel = live.SteeringPanel()\\npanel"]}) as lab:
        lab.run_cells(2)                     # Shift+Enter, as a student runs them
        lab.driver.find_element(...)

Needs Chromium and its driver (Debian: ``apt-get install chromium chromium-driver``) and
selenium (``pip install selenium``); :func:`available` says whether they are there.
"""
from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def available() -> str | None:
    """None when JupyterLab can be driven here, else why not."""
    if shutil.which("chromium") is None and shutil.which("chromium-browser") is None:
        return "Chromium is not installed (Debian: apt-get install chromium chromium-driver)"
    if shutil.which("chromedriver") is None:
        return "chromedriver is not installed (Debian: apt-get install chromium-driver)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium)"
    return None


def _kernel_idle(driver) -> bool:
    """The notebook toolbar's execution indicator says idle (JupyterLab and Notebook 7)."""
    return bool(driver.find_elements("css selector", ".jp-Notebook-ExecutionIndicator[data-status='idle']"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def notebook(cells: list[str]) -> dict:
    return {"cells": [{"cell_type": "code", "execution_count": None, "id": f"c{k}", "metadata": {}, "outputs": [],
                       "source": source} for k, source in enumerate(cells)],
            "metadata": {"kernelspec": {"display_name": "Python 3 (ipykernel)", "language": "python",
                                        "name": "python3"}},
            "nbformat": 4, "nbformat_minor": 5}


class Lab:
    """A JupyterLab server on a free port with ``files`` (``{name: [cell sources]}``) in a
    temporary folder, and a headless Chromium (``self.driver``) showing the first file."""

    def __init__(self, files: dict, width: int = 1280, height: int = 1000, timeout_s: float = 90.0,
                 app: str = "lab"):
        if app not in ("lab", "notebook"):
            raise ValueError(f"app: expected 'lab' (JupyterLab) or 'notebook' (Notebook 7), got {app!r}")
        self.files, self.size, self.timeout, self.app = files, (width, height), timeout_s, app
        self.showing: tuple[str, str] | None = None                    # (file, app) in the browser

    def __enter__(self) -> "Lab":
        try:
            return self._start()
        except BaseException:
            self.__exit__(None, None, None)
            raise

    def _start(self) -> "Lab":
        from selenium import webdriver
        self.folder = tempfile.TemporaryDirectory()
        for name, cells in self.files.items():
            Path(self.folder.name, name).write_text(json.dumps(notebook(cells)), encoding="utf-8")
        self.port, self.token = _free_port(), "motionlab"
        env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        self.log = open(Path(self.folder.name, "lab.log"), "w")
        self.server = subprocess.Popen(
            [sys.executable, "-m", "jupyter", self.app, "--no-browser", f"--port={self.port}", "--ip=127.0.0.1",
             f"--IdentityProvider.token={self.token}", f"--ServerApp.root_dir={self.folder.name}",
             "--ServerApp.disable_check_xsrf=True", "--LabApp.news_url=", "--LabApp.check_for_updates_class="
             "jupyterlab.NeverCheckForUpdate", *(["--allow-root"] if os.geteuid() == 0 else [])], stdout=self.log, stderr=subprocess.STDOUT, env=env)
        self._wait_for_server()
        options = webdriver.ChromeOptions()
        for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     f"--window-size={self.size[0]},{self.size[1]}"):
            options.add_argument(flag)
        options.binary_location = shutil.which("chromium") or shutil.which("chromium-browser")
        os.environ.setdefault("SE_AVOID_STATS", "true")            # selenium: no network calls
        self.driver = webdriver.Chrome(options=options,
                                       service=webdriver.ChromeService(executable_path=shutil.which("chromedriver")))
        self.open(next(iter(self.files)), self.app)
        return self

    def open(self, name: str, app: str | None = None) -> None:
        """Show the file ``name`` in ``app`` (``"lab"`` or ``"notebook"``; default: the server's
        own) and wait for its kernel. One server serves both where Notebook 7 is installed,
        so one server and one browser can test both apps, each on a file of its own. A file
        already shown is left as it is."""
        app = app or self.app
        if app not in ("lab", "notebook") or name not in self.files:
            raise ValueError(f"open: expected one of {list(self.files)} in 'lab' or 'notebook', "
                             f"got {name!r} in {app!r}")
        if self.showing == (name, app):
            return
        where = "lab/tree" if app == "lab" else "notebooks"
        self.driver.get(f"http://127.0.0.1:{self.port}/{where}/{name}?token={self.token}")
        self.wait_for(lambda d: d.find_elements("css selector", ".jp-Notebook .jp-Cell"), "the notebook to open")
        self.wait_for(_kernel_idle, "the kernel to start")
        self.showing = (name, app)

    def _wait_for_server(self) -> None:
        import urllib.request
        deadline = time.time() + self.timeout
        while time.time() < deadline:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.port}/api/status?token={self.token}", timeout=2)
                return
            except OSError:
                time.sleep(0.5)
        raise RuntimeError(f"JupyterLab did not start: see {self.log.name}")

    def wait_for(self, condition, what: str, timeout_s: float | None = None):
        from selenium.webdriver.support.ui import WebDriverWait
        return WebDriverWait(self.driver, timeout_s or self.timeout).until(condition, f"waiting for {what}")

    def click(self, find, what: str) -> None:
        """Click the element ``find(driver)`` returns; the page may still be re-drawing, so an
        element that went stale between finding and clicking, or that is not yet clickable
        (laid out, uncovered), is found again until the timeout."""
        from selenium.common.exceptions import (ElementClickInterceptedException, ElementNotInteractableException,
                                                NoSuchElementException, StaleElementReferenceException)

        def attempt(driver):
            try:
                element = find(driver)
                driver.execute_script("arguments[0].scrollIntoView({block: 'center'});", element)
                element.click()
                return True
            except (StaleElementReferenceException, ElementNotInteractableException,
                    ElementClickInterceptedException, NoSuchElementException, IndexError):
                return False
        self.wait_for(attempt, what)

    def _prompt_element(self, index: int):
        """Cell ``index``'s prompt element (``IndexError`` while the cell is not drawn yet)."""
        return self.driver.find_elements("css selector", ".jp-Notebook .jp-Cell")[index].find_element(
            "css selector", ".jp-InputArea-prompt")

    def _click_prompt(self, index: int) -> None:
        """Click cell ``index``'s prompt (selecting it)."""
        self.click(lambda d: self._prompt_element(index), f"cell {index}'s prompt")

    def _prompt(self, index: int) -> str:
        """Cell ``index``'s prompt text: ``[ ]:`` not run, ``[*]:`` running or queued, ``[k]:`` run."""
        from selenium.common.exceptions import NoSuchElementException, StaleElementReferenceException
        try:
            return self._prompt_element(index).text
        except (StaleElementReferenceException, NoSuchElementException, IndexError):
            return ""

    def _started(self, index: int, before: str) -> bool:
        """Cell ``index``'s prompt is no longer ``before`` and shows it running or run."""
        prompt = self._prompt(index)
        return prompt != before and ("*" in prompt or any(c.isdigit() for c in prompt))

    def run_cells(self, n: int) -> None:
        """Run the first ``n`` cells with Shift+Enter, one after another, as a student would."""
        for index in range(n):
            self.run_cell(index)

    def run_cell(self, index: int, tries: int = 3) -> None:
        """Select cell ``index`` (a click on its prompt) and run it with Shift+Enter; wait until
        its prompt shows that it started (``[*]`` or a new count). A key pressed while the page
        is still settling can be lost: then select the cell and press again, ``tries`` times."""
        from selenium.common.exceptions import TimeoutException
        from selenium.webdriver.common.action_chains import ActionChains
        from selenium.webdriver.common.keys import Keys
        before = self._prompt(index)
        for _ in range(tries):
            self._click_prompt(index)
            ActionChains(self.driver).key_down(Keys.SHIFT).send_keys(Keys.ENTER).key_up(Keys.SHIFT).perform()
            try:
                self.wait_for(lambda d: self._started(index, before), f"cell {index} to start", timeout_s=10.0)
                return
            except TimeoutException:
                continue
        raise TimeoutException(f"cell {index} did not start after {tries} Shift+Enter (prompt {self._prompt(index)!r})")

    def wait_idle(self, timeout_s: float | None = None) -> None:
        """Wait until no cell is running (no ``[*]`` prompt) and the kernel is idle."""
        def idle(driver):
            prompts = [p.text for p in driver.find_elements("css selector", ".jp-InputArea-prompt")]
            return not any("*" in p for p in prompts) and _kernel_idle(driver)
        self.wait_for(idle, "the cells to finish", timeout_s)

    def start_panel(self):
        """Press the live panel's start button and click its picture (which arms its keys), as
        a student would; returns the panel's element once its first frames have come."""
        # the kernel is idle before the widget's view is drawn: wait for the panel itself
        box = self.wait_for(lambda d: (d.find_elements("css selector", ".motionlab-live") or [None])[0],
                            "the live panel to be drawn")
        self.click(lambda d: box.find_element("xpath", ".//button[contains(., 'start')]"), "the start button")
        self.click(lambda d: box.find_element("css selector", "canvas"), "the panel's picture")
        time.sleep(1.0)
        return box

    def keys(self, down=(), up=()) -> None:
        """Release the keys ``up`` and press the keys ``down`` (selenium ``Keys`` names, e.g.
        ``"ARROW_UP"``), each as its own key event, as a held key reaches the page."""
        from selenium.webdriver.common.action_chains import ActionChains
        from selenium.webdriver.common.keys import Keys
        for name in up:
            ActionChains(self.driver).key_up(getattr(Keys, name)).perform()
        for name in down:
            ActionChains(self.driver).key_down(getattr(Keys, name)).perform()

    def outputs(self, index: int) -> str:
        """The text of cell ``index``'s outputs."""
        cells = self.driver.find_elements("css selector", ".jp-Notebook .jp-Cell")
        return cells[index].find_element("css selector", ".jp-Cell-outputWrapper").text

    def __exit__(self, *exc) -> None:
        driver, server = getattr(self, "driver", None), getattr(self, "server", None)
        try:
            if driver is not None:
                driver.quit()
        finally:
            if server is not None:
                server.terminate()
                try:
                    server.wait(10)
                except subprocess.TimeoutExpired:
                    server.kill()
            if getattr(self, "log", None) is not None:
                self.log.close()
            if getattr(self, "folder", None) is not None:
                self.folder.cleanup()
