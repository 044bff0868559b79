#!/usr/bin/env python3
"""Drives the page of `mbmf teach` / `mbmf view` (src/web/page.html) in headless Chromium, as a
person would, for the Rust tests.

    python tests/browser/teach_browser.py SCENARIO URL [URL2]

    teach URL              agree to the consent if shown, pace to the minimum, congratulate one
                           step, punish a later one, take over (put in the red box), see ~20 more
                           steps, then close the tab mid-session. Prints
                           {"congratulated":[..],"punished":[..],"takeover_step":N,"last_step_seen":M}
    two URL URL2           two browsers at once, one congratulation each. Prints
                           {"first":{"participant":..,"last_step_seen":..},"second":{..}}
    view URL               a replay: 3 x forward, then the scrub slider to the end. Prints
                           {"rows":N,"step_after_scrub":M}
    screenshot PATH URL    agree, a few steps, a 1200x800 PNG at PATH. Prints
                           {"screenshot":PATH,"last_step_seen":M}

One JSON line on stdout on success (exit 0); on any failure or timeout a message on stderr
(with the page's state, status line and last messages) and exit 1; exit 2 for bad usage. Each
scenario takes under 60 s. Needs selenium (scripts/browser-env.sh) and Debian's chromium and
chromium-driver at /usr/bin/chromium and /usr/bin/chromedriver.

The page exposes what it received (window.mbmfLog), what it sent (window.mbmfSent) and every
step it showed with the actor text as read from the page (window.mbmfShown); the steps printed
are those the server acknowledged.
"""

import json
import os
import sys
import time

try:
    from selenium import webdriver
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
except ImportError:
    print("teach_browser: selenium is not installed (run scripts/browser-env.sh and use the python "
          "it prints)", file=sys.stderr)
    sys.exit(1)

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
BUDGET_S = 55.0  # the whole scenario, browser start included
POLL_S = 0.02

START = time.monotonic()


class Failure(Exception):
    pass


def remaining():
    return START + BUDGET_S - time.monotonic()


def wait_until(fn, what, timeout=30.0):
    """Polls fn until it returns something truthy, which is returned."""
    limit = time.monotonic() + min(timeout, remaining())
    while True:
        value = fn()
        if value:
            return value
        if time.monotonic() >= limit:
            spent = "the scenario's time" if remaining() <= 0 else f"{timeout:.0f} s"
            raise Failure(f"timed out ({spent}) waiting for {what}")
        time.sleep(POLL_S)


def make_driver():
    for path in (CHROMIUM, CHROMEDRIVER):
        if not os.access(path, os.X_OK):
            raise Failure(f"{path} is missing (run scripts/browser-env.sh)")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1200,800",
                "--disable-dev-shm-usage", "--no-first-run", "--disable-extensions"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    try:
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    except WebDriverException as e:
        raise Failure(f"could not start headless Chromium: {e.msg or e}") from e
    driver.set_page_load_timeout(max(5.0, min(20.0, remaining())))
    driver.set_script_timeout(10)
    return driver


class Page:
    """One browser tab on the page."""

    def __init__(self, name):
        self.name = name
        self.driver = make_driver()

    def js(self, script, *args):
        return self.driver.execute_script(script, *args)

    def state(self):
        return self.js("return document.body.dataset.state || ''")

    def step(self):
        s = self.js("return document.body.dataset.step || ''")
        return int(s) if s else None

    def live_step(self):
        """The step shown (0 before the first); fails once the session is over."""
        state = self.state()
        if state in ("closed", "finished"):
            raise Failure(f"the session ended early ({state}: {self.status()})")
        return self.step() or 0

    def el(self, id_):
        return self.driver.find_element(By.ID, id_)

    def enabled(self, id_):
        return self.js("const e = document.getElementById(arguments[0]); "
                       "return !!e && !e.disabled && e.offsetParent !== null;", id_)

    def log_len(self):
        return self.js("return window.mbmfLog ? window.mbmfLog.length : 0")

    def log_since(self, n, types):
        return self.js("return (window.mbmfLog || []).slice(arguments[0])"
                       ".filter(m => arguments[1].includes(m.type));", n, types)

    def sent(self, kind):
        return self.js("return (window.mbmfSent || []).filter(m => m.type === arguments[0]);", kind)

    def open(self, url, want=("consent", "running")):
        self.driver.get(url)
        wait_until(lambda: self.js("return typeof window.mbmfLog === 'object'"), "the page's script")

        def ready():
            s = self.state()
            if s == "closed":
                raise Failure(f"the page closed at once: {self.status()}")
            if s and s not in want:
                raise Failure(f"the page is in state {s!r}, expected {' or '.join(want)}")
            return s in want and s

        return wait_until(ready, f"the page to be in state {' or '.join(want)}", 15)

    def start(self, url):
        """Opens a teaching page and agrees to the consent if it is shown."""
        if self.open(url) == "consent":
            self.el("agree").click()
            wait_until(lambda: self.state() == "running", "the run to start after the consent", 10)

    def status(self):
        try:
            return self.el("status").text
        except WebDriverException:
            return "?"

    def set_range(self, id_, value):
        self.js("const e = document.getElementById(arguments[0]); e.value = String(arguments[1]); "
                "e.dispatchEvent(new Event('input', {bubbles: true})); "
                "e.dispatchEvent(new Event('change', {bubbles: true}));", id_, value)

    def pace_to_minimum(self):
        self.set_range("pace", 100)
        wait_until(lambda: self.js("return document.getElementById('pace').value") == "100",
                   "the pace slider at 100 ms")

    def first_step(self):
        return wait_until(self.live_step, "a first step to be shown", 20)

    def feedback(self, button, after_step):
        """Clicks congratulate/punish on a step after after_step (retrying while the steps race
        by); returns the step the server acknowledged."""
        event = "congratulation" if button == "congratulate" else "punishment"
        for _ in range(20):
            wait_until(lambda: self.live_step() > after_step and self.enabled(button),
                       f"'{button}' to be enabled on a step after {after_step}", 20)
            before_sent, before_log = len(self.sent("feedback")), self.log_len()
            try:
                self.el(button).click()
            except WebDriverException:
                continue
            sent = self.sent("feedback")
            if len(sent) == before_sent:
                continue  # the button went disabled under the click: the next step
            step = sent[-1]["step"]

            def answer():
                for m in self.log_since(before_log, ["feedback", "refused"]):
                    if m["type"] == "refused" or m.get("step") == step:
                        return m
                return None

            reply = wait_until(answer, f"the server's answer to the {event} of step {step}", 10)
            if reply["type"] == "refused":
                print(f"teach_browser: {self.name}: {event} of step {step} refused "
                      f"({reply.get('reason')}), trying again", file=sys.stderr)
                continue
            if reply.get("event") != event:
                raise Failure(f"feedback on step {step} acknowledged as {reply.get('event')!r}, "
                              f"not {event!r}")
            return step
        raise Failure(f"could not {button} any step")

    def takeover(self, target="put-red"):
        """Clicks a box target while the robot holds a cube; returns the step shown with actor
        'human'."""
        for _ in range(20):
            wait_until(lambda: self.live_step() and self.enabled(target),
                       f"'{target}' to be enabled (robot holding)", 30)
            before_sent, before_log = len(self.sent("takeover")), self.log_len()
            before_shown = self.js("return window.mbmfShown.length")
            try:
                self.el(target).click()
            except WebDriverException:
                continue
            if len(self.sent("takeover")) == before_sent:
                continue

            def answer():
                shown = self.js("return window.mbmfShown.slice(arguments[0])"
                                ".filter(s => s.actor === 'human');", before_shown)
                if shown:
                    return shown[0]
                refused = self.log_since(before_log, ["refused"])
                return refused[0] if refused else None

            reply = wait_until(answer, "a step with actor 'human' after the takeover", 10)
            if "type" in reply:
                print(f"teach_browser: {self.name}: takeover refused ({reply.get('reason')}), "
                      "trying again", file=sys.stderr)
                continue
            return reply["step"]
        raise Failure(f"could not take over with '{target}'")

    def acked(self, event):
        return self.js("return (window.mbmfLog || []).filter(m => m.type === 'feedback' && "
                       "m.event === arguments[0]).map(m => m.step);", event)

    def participant(self):
        return self.js("const h = (window.mbmfLog || []).find(m => m.type === 'hello'); "
                       "return h ? h.participant : null;")

    def check_console(self):
        """Fails on an uncaught script error or a blocked resource (CSP) in the page."""
        try:
            entries = self.driver.get_log("browser")
        except WebDriverException:
            return
        for e in entries:
            text = e.get("message", "")
            if e.get("level") == "SEVERE" and ("Uncaught" in text or "Content Security Policy" in text):
                raise Failure(f"the page's console: {text}")

    def diagnose(self):
        try:
            tail = self.js("return JSON.stringify((window.mbmfLog || []).slice(-4))")
            logs = [e.get("message", "") for e in self.driver.get_log("browser")][-5:]
            return (f"{self.name}: state={self.state()!r} step={self.step()!r} "
                    f"status={self.status()!r} last messages={tail} console={logs}")
        except Exception as e:  # the browser itself may be gone
            return f"{self.name}: no diagnosis ({e})"

    def quit(self):
        try:
            self.driver.quit()
        except Exception:
            pass


def teach(pages, url):
    page = Page("teach")
    pages.append(page)
    page.start(url)
    page.pace_to_minimum()
    first = page.first_step()
    congratulated = page.feedback("congratulate", first - 1)
    page.feedback("punish", congratulated)
    takeover_step = page.takeover("put-red")
    wait_until(lambda: page.live_step() >= takeover_step + 20, "20 more steps after the takeover")
    page.check_console()
    result = {"congratulated": page.acked("congratulation"), "punished": page.acked("punishment"),
              "takeover_step": takeover_step, "last_step_seen": page.step()}
    page.quit()  # the tab closes mid-session
    pages.remove(page)
    return result


def two(pages, url, url2):
    first, second = Page("first"), Page("second")
    pages += [first, second]
    for page, u in ((first, url), (second, url2)):
        page.start(u)
    for page in (first, second):
        page.pace_to_minimum()
    result = {}
    for key, page in (("first", first), ("second", second)):
        page.feedback("congratulate", page.first_step() - 1)
    for key, page in (("first", first), ("second", second)):
        page.check_console()
        result[key] = {"participant": page.participant(), "last_step_seen": page.step()}
    for page in (first, second):
        page.quit()
        pages.remove(page)
    return result


# Sent by a second tab on its own WebSocket: each must close that socket only.
HOSTILE = [
    "not json",
    '{"type":"load","file":"/etc/passwd"}',
    '{"type":"pace","ms":1,"path":"../runs"}',
    '{"type":"feedback","step":1,"sign":1000}',
    "x" * 4096,
]


def hostile(pages, url):
    page, other = Page("person"), Page("hostile")
    pages += [page, other]
    page.start(url)
    page.pace_to_minimum()
    before = page.first_step()
    other.driver.get(url)
    closes = []
    for text in HOSTILE:
        # A raw socket from the same page origin, as a tampered tab would open it.
        code = other.driver.execute_async_script(
            """
            const [text, done] = arguments;
            const ws = new WebSocket((location.protocol === 'https:' ? 'wss' : 'ws') +
                                     '://' + location.host + '/ws');
            let sent = false;
            ws.onmessage = (e) => {
              if (!sent) { sent = true; ws.send(text); }
            };
            ws.onclose = (e) => done([e.code, e.reason]);
            setTimeout(() => done(['open', '']), 8000);
            """, text)
        closes.append(code)
    still = [c for c in closes if c[0] == "open"]
    if still:
        raise Failure(f"a hostile message did not close its socket: {still}")
    after = wait_until(lambda: page.live_step() >= before + 20 and page.live_step(),
                       "the person's session to go on", 20)
    if page.state() != "running":
        raise Failure(f"the person's session is {page.state()} after the hostile messages")
    page.feedback("congratulate", after)
    page.check_console()
    result = {"closes": closes, "step_before": before, "step_after": page.step(),
              "congratulated": page.acked("congratulation")}
    for p_ in (page, other):
        p_.quit()
        pages.remove(p_)
    return result


def view(pages, url):
    page = Page("view")
    pages.append(page)
    page.open(url, want=("paused", "running"))
    steps = wait_until(lambda: page.js(
        "const r = (window.mbmfLog || []).find(m => m.type === 'replay'); "
        "return r ? r.rows.map(x => x.step) : null;"), "the replay")
    if len(steps) < 2:
        raise Failure(f"the replay has {len(steps)} rows: nothing to step through")
    for id_ in ("back", "forward", "play", "scrub"):
        if not page.el(id_).is_displayed():
            raise Failure(f"the replay control '{id_}' is not shown")
    for id_ in ("congratulate", "punish", "pause", "pace"):
        if page.el(id_).is_displayed():
            raise Failure(f"the teaching control '{id_}' is shown in view mode")
    shown = wait_until(page.step, "the first replayed step")
    index = steps.index(shown)
    for _ in range(3):
        before = page.step()
        page.el("forward").click()
        index = min(index + 1, len(steps) - 1)
        want = steps[index]
        wait_until(lambda: page.step() == want, f"'forward' from step {before} to step {want}", 5)
    if page.step() <= shown:
        raise Failure(f"'forward' did not advance: step {page.step()} after {shown}")
    scrub = page.el("scrub")
    scrub.click()
    scrub.send_keys(Keys.END)
    try:
        wait_until(lambda: page.step() == steps[-1], "the scrub slider at its end", 3)
    except Failure:
        page.set_range("scrub", len(steps) - 1)
        wait_until(lambda: page.step() == steps[-1], "the scrub slider at its end", 3)
    page.check_console()
    result = {"rows": len(steps), "step_after_scrub": page.step()}
    page.quit()
    pages.remove(page)
    return result


def screenshot(pages, path, url):
    page = Page("screenshot")
    pages.append(page)
    page.driver.set_window_size(1200, 800)
    state = page.open(url, want=("consent", "running", "paused"))
    mode = page.js("const h = (window.mbmfLog || []).find(m => m.type === 'hello'); "
                   "return h ? h.mode : null;")
    if mode == "view":
        for _ in range(3):
            page.el("forward").click()
    else:
        if state == "consent":
            page.el("agree").click()
            wait_until(lambda: page.state() == "running", "the run to start after the consent", 10)
        page.set_range("pace", 300)
        wait_until(lambda: page.js("return window.mbmfShown.length") >= 4, "a few steps", 30)
        time.sleep(1.3)  # let a feedback flash fade
    page.check_console()
    if not page.driver.save_screenshot(path):
        raise Failure(f"could not save the screenshot to {path}")
    with open(path, "rb") as f:
        if f.read(8) != b"\x89PNG\r\n\x1a\n":
            raise Failure(f"{path} is not a PNG")
    result = {"screenshot": path, "last_step_seen": page.step()}
    page.quit()
    pages.remove(page)
    return result


def main(argv):
    usage = ("usage: teach_browser.py teach URL | two URL URL2 | hostile URL | view URL | "
             "screenshot PATH URL")
    if len(argv) < 2:
        print(usage, file=sys.stderr)
        return 2
    scenario, args = argv[1], argv[2:]
    runs = {"teach": (teach, 1), "two": (two, 2), "view": (view, 1), "screenshot": (screenshot, 2),
            "hostile": (hostile, 1)}
    if scenario not in runs or len(args) != runs[scenario][1]:
        print(usage, file=sys.stderr)
        return 2
    if scenario == "screenshot" and args[0].startswith(("http://", "https://")):
        args = args[::-1]  # screenshot URL PATH
    pages = []
    try:
        result = runs[scenario][0](pages, *args)
    except (Failure, WebDriverException) as e:
        message = e.msg if isinstance(e, WebDriverException) and e.msg else str(e)
        print(f"teach_browser: {scenario}: FAILED: {message}", file=sys.stderr)
        for page in pages:
            print(f"teach_browser: {page.diagnose()}", file=sys.stderr)
        return 1
    finally:
        for page in pages:
            page.quit()
    print(json.dumps(result), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
