"""The pages in a real headless Chromium (Selenium) against a live server with the scripted model.

Skipped where Chromium or its driver is missing (Debian: `apt-get install chromium chromium-driver`);
CI installs both. Set URDFKB_SCREENSHOTS=DIR to keep a screenshot of each page there (docs/ does).
"""
from __future__ import annotations

import dataclasses
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from urdfkb.pipeline.llm.scripted import ScriptedBackend
from urdfkb.pipeline.runner import run

from tests.kb_fixtures import running
from tests.toy_robot import TOY, perfect

CHROMIUM = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
DRIVER = shutil.which("chromedriver")
pytestmark = [pytest.mark.browser, pytest.mark.skipif(
    not (CHROMIUM and DRIVER),
    reason="headless Chromium and chromedriver not found: install Debian's chromium and chromium-driver to run the browser tests")]

SHOTS = os.environ.get("URDFKB_SCREENSHOTS")


def scripted_runner(tree, settings, progress):
    """The real pipeline with the scripted 'perfect' model of the toy robot (no cache writes)."""
    return run(tree, dataclasses.replace(settings, use_cache=False), backend=ScriptedBackend(perfect), progress=progress)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    from urdfkb.kb_server.serve import make_server
    server, store, jobs = make_server(tmp_path_factory.mktemp("kb") / "kb.sqlite3", port=0, runner=scripted_runner)
    with running(server):
        yield f"http://127.0.0.1:{server.effective_port}"
    jobs.shutdown()
    store.close()


@pytest.fixture(scope="module")
def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="urdfkb-chromium-")
    options = webdriver.ChromeOptions()
    assert CHROMIUM is not None  # the browser lane is skipped without one
    options.binary_location = CHROMIUM
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--disable-dev-shm-usage", f"--user-data-dir={profile}", "--window-size=1500,1000"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=DRIVER), options=options)
    driver.implicitly_wait(0)
    yield driver
    driver.quit()
    shutil.rmtree(profile, ignore_errors=True)


def wait_for(driver, css, timeout=30, text=None):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support import expected_conditions as EC
    from selenium.webdriver.support.ui import WebDriverWait

    locator = (By.CSS_SELECTOR, css)
    condition = EC.text_to_be_present_in_element(locator, text) if text else EC.presence_of_element_located(locator)
    WebDriverWait(driver, timeout).until(condition)
    return driver.find_element(*locator)


def shot(driver, name):
    if SHOTS:
        Path(SHOTS).mkdir(parents=True, exist_ok=True)
        driver.execute_script("window.scrollTo(0, 0)")
        driver.save_screenshot(str(Path(SHOTS) / f"{name}.png"))


def upload(driver, base, path: Path, structure_only=False):
    driver.get(base + "/")
    driver.find_element("id", "file").send_keys(str(path))
    if structure_only:
        driver.find_element("id", "structure_only").click()
    driver.find_element("id", "populate").click()
    wait_for(driver, "#job-state", text="succeeded")
    return driver.find_element("id", "job-result")


def row_of(driver, link):
    return driver.find_element("css selector", f'tr.component-row[data-links~="{link}"]')


def test_upload_review_repopulate_in_the_browser(server, browser):
    from selenium.webdriver.support.ui import Select

    result = upload(browser, server, TOY)
    assert "Open toy_robot" in result.text
    browser.get(server + "/")
    robots = wait_for(browser, "#robots")
    assert "toy_robot" in robots.text
    shot(browser, "index")

    browser.find_element("link text", "toy_robot").click()
    svg = wait_for(browser, "svg.tree")
    assert len(svg.find_elements("css selector", "g.component")) == 3
    assert "mast_rgbd_color_optical" in svg.text  # links are labelled
    assert svg.find_elements("css selector", "path.mount")
    table = browser.find_element("id", "components")
    assert {"Lidar", "RGBDCamera", "ParallelGripper"} <= {c.text for c in table.find_elements("css selector", ".cls")}
    confidences = [float(c.text) for c in table.find_elements("css selector", "tr.component-row td.num")]
    assert confidences == sorted(confidences)  # least confident first

    # change the scanner's class: the choice offers only classes the ontology allows there
    row = row_of(browser, "front_scanner")
    choice = Select(row.find_element("css selector", ".class-choice"))
    offered = [o.text for o in choice.options]
    assert "Sonar" in offered and "ParallelGripper" not in offered and "RGBDCamera" not in offered
    browser.find_element("id", "reviewer").send_keys("Quinn\t")
    choice.select_by_visible_text("Sonar")
    row.find_element("css selector", 'button[data-action="reclassify"]').click()
    wait_for(browser, 'tr.component-row[data-links~="front_scanner"] .badge.reviewed')

    browser.refresh()
    row = wait_for(browser, 'tr.component-row[data-links~="front_scanner"]')
    assert row.find_element("css selector", ".cls").text == "Sonar"
    assert "corrected by Quinn" in row.text
    shot(browser, "robot")

    # populate the same robot again: the model says Lidar, the correction wins and is reported
    result = upload(browser, server, TOY)
    assert "re-applied: front_scanner: class -> Sonar (Quinn)" in result.find_element("id", "job-corrections").text
    browser.get(server + "/robots/toy_robot")
    assert row_of(browser, "front_scanner").find_element("css selector", ".cls").text == "Sonar"

    # and from the robot page itself, from the stored URDF
    browser.find_element("id", "repopulate").click()
    wait_for(browser, "#job-state", text="succeeded")
    assert "re-applied: front_scanner: class -> Sonar" in browser.find_element("id", "job-corrections").text
    browser.refresh()
    assert row_of(browser, "front_scanner").find_element("css selector", ".cls").text == "Sonar"


def test_query_page_runs_a_bundled_query(server, browser):
    from selenium.webdriver.support.ui import Select

    browser.get(server + "/sparql")
    Select(wait_for(browser, "#preset")).select_by_value(
        str([o.text.split(":")[0] for o in Select(browser.find_element("id", "preset")).options].index("sensors")))
    assert "core:Sensor" in browser.find_element("id", "query").get_attribute("value")
    browser.find_element("id", "run").click()
    table = wait_for(browser, "#result-table")
    assert "mast_rgbd" in table.text or "front_scanner" in table.text
    assert "row" in browser.find_element("id", "message").text
    shot(browser, "sparql")


def body_row(driver, part):
    return driver.find_element("css selector", f'tr.body-row[data-part="{part}"]')


def joints_of(driver, part):
    return [li.text for li in body_row(driver, part).find_elements("css selector", "ol.joints li")]


def test_body_parts_are_shown_corrected_and_kept_across_a_repopulate(server, browser):
    from selenium.webdriver.support.ui import Select

    upload(browser, server, TOY)
    browser.get(server + "/robots/toy_robot")
    svg = wait_for(browser, "svg.tree")
    assert {g.get_attribute("data-part") for g in svg.find_elements("css selector", "g.body-part")} == {
        "body_mobile_base_chassis", "body_wheel_wl", "body_wheel_wr", "body_arm_a1"}
    rows = browser.find_elements("css selector", "#body tr.body-row")
    assert {r.get_attribute("data-part"): r.find_element("css selector", ".cls").text for r in rows} == {
        "mobile_base_chassis": "MobileBase", "wheel_wl": "Wheel", "wheel_wr": "Wheel", "arm_a1": "Arm"}
    assert body_row(browser, "wheel_wl").find_element("css selector", ".side").text == "left"
    assert joints_of(browser, "arm_a1") == ["a1", "a2", "a3"]
    assert "ParallelGripper" in body_row(browser, "arm_a1").find_element("css selector", ".located").text
    assert "RGBDCamera" in body_row(browser, "mobile_base_chassis").find_element("css selector", ".located").text

    # split the arm at its second joint, then give the new forearm a side, through the page
    row = body_row(browser, "arm_a1")
    row.find_element("css selector", "details.review summary").click()
    Select(row.find_element("css selector", ".part-at")).select_by_visible_text("a2")
    row.find_element("css selector", 'button[data-body="split"]').click()
    wait_for(browser, 'tr.body-row[data-part="arm_a1"] .badge.reviewed')
    row = body_row(browser, "arm_a2")
    row.find_element("css selector", "details.review summary").click()
    Select(row.find_element("css selector", ".part-side")).select_by_visible_text("right")
    row.find_element("css selector", 'button[data-body="side"]').click()
    wait_for(browser, 'tr.body-row[data-part="arm_a2"] .side', text="right")

    def corrected():
        assert joints_of(browser, "arm_a1") == ["a1"] and joints_of(browser, "arm_a2") == ["a2", "a3"]
        assert "ParallelGripper" in body_row(browser, "arm_a2").find_element("css selector", ".located").text
        assert body_row(browser, "arm_a2").find_element("css selector", ".side").text == "right"
        assert len(browser.find_elements("css selector", 'g.body-part[data-part="body_arm_a2"] text.side')) == 2

    corrected()
    shot(browser, "robot_body")

    # populate again from the page, from the stored URDF: both corrections are re-applied
    browser.find_element("id", "repopulate").click()
    wait_for(browser, "#job-state", text="succeeded")
    applied = browser.find_element("id", "job-corrections").text
    assert "re-applied: body part arm_a1: split at a2" in applied and "re-applied: body part arm_a2: side -> right" in applied
    browser.refresh()
    wait_for(browser, 'tr.body-row[data-part="arm_a2"]')
    corrected()
