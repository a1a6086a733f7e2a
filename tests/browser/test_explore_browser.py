#!/usr/bin/env python3
"""tests/browser/test_explore_browser.py: `specula explore` in a real browser (headless Chromium
driven by Selenium). Starts the explorer on scenes/caustic_glass_sphere.xml on a free port, clicks a
receiver point inside the glass ball's caustic, reads #solver-status as converged, drags the point
to another point of the caustic, reads it converged again (at the new point), checks the loss map
and the 2D view drew something, and saves a screenshot. Everything missing (Selenium, Chromium,
chromedriver, WebGL) fails the test: .ci/run installs them.

usage: test_explore_browser.py BUILD/specula [SCREENSHOT.png]
"""
import os
import re
import subprocess
import sys
import time

SCENE = "scenes/caustic_glass_sphere.xml"
# Floor points in the ball's caustic, seen by the scene's camera, where the angular solver
# converges from the straight seed (found with /api/solve; tests/test_explore.c uses the first).
CLICK = [0.2, 0.0, 0.1]
DRAG_TO = [0.2, 0.0, 0.2]
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)


def http_checks(url):
    """The server answers bad requests with a 4xx and a message, and keeps serving."""
    import json
    import urllib.error
    import urllib.request

    def req(path, body=None, method=None):
        data = body.encode() if isinstance(body, str) else body
        r = urllib.request.Request(url.rstrip("/") + path, data=data, method=method)
        try:
            with urllib.request.urlopen(r, timeout=30) as f:
                return f.status, f.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    good = '{"receiver": {"origin": [0.2, 0.05, 0.14], "direction": [0, -1, 0]}}'
    cases = [("/api/solve", "{bad", 400, b"malformed JSON"),
             ("/api/solve", " " * 20000, 413, b"too large"),
             ("/api/solve", good[:-1] + ', "max_chain": 99}', 400, b"out of range"),
             ("/api/solve", good[:-1] + ', "time_limit": -1}', 400, b"out of range"),
             ("/api/nothing", None, 404, b"no such API path"),
             ("/../../etc/passwd", None, 404, b"not found"),
             ("/three.min.js/../index.html", None, 404, b"not found")]
    for path, body, status, msg in cases:
        st, text = req(path, body)
        check(st == status and msg in text, "%s %r... -> %d %r" % (path, (body or "")[:20], st, text[:60]))
    st, text = req("/api/solve", good)
    check(st == 200 and json.loads(text)["runs"][0]["success"], "a good solve after the bad requests")
    r = urllib.request.Request(url.rstrip("/") + "/api/scene", headers={"Host": "evil.example:80"})
    try:
        urllib.request.urlopen(r, timeout=30)
        st = 200
    except urllib.error.HTTPError as e:
        st = e.code
    check(st == 403, "a request with a foreign Host header is refused (%d)" % st)
    st, text = req("/three.min.js")
    check(st == 200 and b"THREE" in text[:4000], "three.js served")


def main():
    specula = sys.argv[1]
    shot = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(specula), "explore_browser.png")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
        from selenium.webdriver.common.action_chains import ActionChains
        from selenium.webdriver.common.by import By
        from selenium.webdriver.support.ui import WebDriverWait
    except ImportError as e:
        print("FAIL selenium is not installed (.ci/run installs python3-selenium): %s" % e)
        return 1
    for path in ("/usr/bin/chromium", "/usr/bin/chromedriver"):
        if not os.path.exists(path):
            print("FAIL %s is missing (.ci/run installs chromium and chromium-driver)" % path)
            return 1

    # the command line's mistakes: a clear message and a nonzero exit, no server
    for args, code, msg in ((["explore"], 2, "no scene given"),
                            (["explore", SCENE, "--port", "70000"], 2, "--port needs a number"),
                            (["explore", SCENE, "--bogus"], 2, "unknown option"),
                            (["explore", "scenes/no_such_scene.xml"], 3, "no_such_scene.xml")):
        p = subprocess.run([specula] + args, capture_output=True, text=True, timeout=60)
        check(p.returncode == code and msg in p.stderr, "specula %s -> exit %d, %r" % (" ".join(args), p.returncode,
                                                                                     p.stderr.strip()[:80]))
    server = subprocess.Popen([specula, "explore", SCENE, "--port", "0"], stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    driver = None
    try:
        line = server.stdout.readline()
        m = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        check(m is not None, "server prints its address: %r" % line.strip())
        if not m:
            return 1
        url = "http://127.0.0.1:%s/" % m.group(1)
        http_checks(url)
        p = subprocess.run([specula, "explore", SCENE, "--port", m.group(1)], capture_output=True, text=True, timeout=60)
        check(p.returncode == 4 and "cannot listen" in p.stderr, "a second server on the same port: exit %d, %r" %
              (p.returncode, p.stderr.strip()))

        opts = webdriver.ChromeOptions()
        opts.binary_location = "/usr/bin/chromium"
        for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1280,860",
                  "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"):
            opts.add_argument(a)
        opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        driver.get(url)
        wait = WebDriverWait(driver, 60)
        wait.until(lambda d: d.find_element(By.ID, "scene-name").text.startswith("scene:")
                   or d.find_element(By.ID, "solver-status").text.startswith("failed"))
        status = driver.find_element(By.ID, "solver-status")
        check(driver.find_element(By.ID, "scene-name").text.startswith("scene:"),
              "page loaded the scene (status: %r)" % status.text)
        canvas = driver.find_element(By.ID, "view3d")

        def offset(p):
            # the point's pixel, as an offset from the canvas' centre (Selenium 4 moves from there)
            x, y = driver.execute_script("return window.specula.project(arguments[0]);", p)
            r = driver.execute_script("const r = arguments[0].getBoundingClientRect();"
                                      "return [r.left + r.width / 2, r.top + r.height / 2];", canvas)
            return int(round(x - r[0])), int(round(y - r[1]))

        def wait_status(prev):
            try:
                WebDriverWait(driver, 30).until(lambda d: status.text != prev and
                                                re.match(r"(converged|failed)", status.text))
            except Exception:
                pass
            return status.text

        dx, dy = offset(CLICK)
        ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click().perform()
        s1 = wait_status("no solve yet: click a surface")
        check(re.fullmatch(r"converged in \d+ iterations?", s1) is not None, "click in the caustic: %r" % s1)
        p1 = driver.execute_script("return window.specula.result().receiver.point;")
        check(abs(p1[0] - CLICK[0]) < 0.01 and abs(p1[2] - CLICK[2]) < 0.01, "receiver at the clicked point %s" % p1)

        ex, ey = offset(DRAG_TO)
        chain = ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click_and_hold()
        steps = 8
        for k in range(1, steps + 1):
            chain = chain.move_to_element_with_offset(canvas, dx + (ex - dx) * k // steps, dy + (ey - dy) * k // steps)
            chain = chain.pause(0.05)
        chain.release().perform()
        # the last solve of the drag is the one at the release point
        WebDriverWait(driver, 30).until(lambda d: abs(d.execute_script(
            "const r = window.specula.result(); return r ? r.receiver.point[2] : 0;") - DRAG_TO[2]) < 0.01)
        time.sleep(0.5)
        s2 = status.text
        p2 = driver.execute_script("return window.specula.result().receiver.point;")
        check(abs(p2[2] - DRAG_TO[2]) < 0.01, "the drag moved the receiver to %s" % p2)
        check(re.fullmatch(r"converged in \d+ iterations?", s2) is not None, "converged again after the drag: %r" % s2)

        # the loss map panel has pixels that are not the background
        WebDriverWait(driver, 30).until(lambda d: "log10 loss" in d.find_element(By.ID, "lossmap-info").text)
        lit = driver.execute_script(
            "const g = document.getElementById('lossmap').getContext('2d').getImageData(0, 0, 320, 320).data;"
            "let n = 0; for (let i = 0; i < g.length; i += 4) if (g[i] + g[i+1] + g[i+2] > 0) ++n; return n;")
        check(lit > 320 * 320 // 2, "loss map drawn (%d lit pixels)" % lit)
        driver.save_screenshot(shot)
        check(os.path.getsize(shot) > 10000, "screenshot saved to %s" % shot)

        # the 2D view: its own solve converges on the built-in glass ball
        driver.find_element(By.ID, "tab2d").click()
        driver.find_element(By.ID, "solve2d").click()
        WebDriverWait(driver, 10).until(lambda d: re.match(r"2D: (converged|failed)", status.text))
        check(status.text.startswith("2D: converged"), "2D view solves: %r" % status.text)
        # every preset: the analytic dL/dtheta against a central difference at 400 angles (where the
        # bounce sequence is the same on both sides), a solve from the preset's start converges, and
        # the loss over theta has roots
        for name in driver.execute_script("return Object.keys(PRESETS);"):
            n, worst, st, roots = driver.execute_script("""
              loadPreset(arguments[0]);
              let worst = 0, n = 0;
              for (let i = 0; i < 400; ++i) {
                const th = -Math.PI + 2 * Math.PI * (i + 0.37) / 400, t = trace2(th), f = fd2(th, 1e-6);
                if (!isFinite(f) || t.L < 1e-12) continue;
                worst = Math.max(worst, Math.abs(t.g - f) / Math.max(Math.abs(t.g), 1e-3 * t.L)); ++n;
              }
              solve2d();
              return [n, worst, document.getElementById('solver-status').textContent, P.roots.length];""", name)
            check(n > 300 and worst < 1e-4 and st.startswith("2D: converged") and "direct" not in st and roots >= 1,
                  "2D preset %r: %d angles, worst derivative error %.2g, %r, %d roots" % (name, n, worst, st, roots))
        driver.execute_script("loadPreset('glass ball'); solve2d();")
        driver.save_screenshot(os.path.splitext(shot)[0] + "_2d.png")

        errors = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
        check(not errors, "no errors in the browser console %s" % errors[:3])
    finally:
        if driver:
            driver.quit()
        server.send_signal(2)
        try:
            out, _ = server.communicate(timeout=10)
            check(server.returncode == 0 and "stopped" in out, "Ctrl-C stops the server cleanly (exit %s)" % server.returncode)
        except subprocess.TimeoutExpired:
            server.kill()
            check(False, "the server did not stop on SIGINT")
    print("%d passed, %d failed" % (0 if failures else 1, len(failures)))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
