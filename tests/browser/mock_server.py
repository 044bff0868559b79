#!/usr/bin/env python3
"""A stand-in for `mbmf teach` / `mbmf view`, for working on src/web/page.html without the Rust
server: serves the page at `/` and speaks the page's WebSocket protocol at `/ws` with a toy tidy1
robot (random takes and puts). Each connection is its own session.

    python tests/browser/mock_server.py [--mode teach|view] [--port 8765] [--task tidy1|tidy2|other]
        [--consent TEXT]
        [--budget N] [--pace MS] [--steps N] [--close-after N] [--log FILE]

Needs the `websockets` package (15.x), e.g. in a private venv:
    python3 -m venv /tmp/mockvenv && /tmp/mockvenv/bin/pip install websockets==15.0.1

Every client message is checked as the real server does (known type, known fields, bounded
values, under 512 bytes); a bad one closes the session with code 1008 and a reason, and is
reported on stderr. With --log, every client message is appended to FILE as one JSON line
(with the session id), so a test can check what the page sent.
"""

import argparse
import asyncio
import http
import json
import random
import sys
from pathlib import Path

from websockets.asyncio.server import serve
from websockets.exceptions import ConnectionClosed

PAGE = Path(__file__).resolve().parents[2] / "src" / "web" / "page.html"
ACTIONS = ["take red", "take green", "take blue", "put in red box", "put in green box",
           "put in blue box", "put on table"]
PLACES = {0: "redbox", 1: "greenbox", 2: "bluebox"}
CSP = ("default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; "
       "img-src data:; connect-src 'self'")
MAX_MESSAGE = 512


TASK = "tidy1"


def name(places):
    """The state's name as the task names it (tidy2: a toy lamp, lit for the cubes already in
    their own box in the order R, G, B; another task: an opaque name)."""
    text = " ".join(f"{c}:{p}" for c, p in zip("RGB", places))
    if TASK == "tidy2":
        leds = 0
        while leds < 3 and places[leds] == PLACES[leds]:
            leds += 1
        return f"{text} LED:{leds}"
    if TASK != "tidy1":
        return f"s{abs(hash(text)) % 100}"
    return text


def apply(places, action):
    """(next places, reward) of a tidy1 action."""
    nxt = list(places)
    held = places.index("hand") if "hand" in places else None
    if action <= 2:
        if held is None:
            nxt[action] = "hand"
    elif held is not None:
        nxt[held] = PLACES[action - 3] if action <= 5 else "table"
    goal = all(nxt[c] == PLACES[c] for c in range(3))
    return nxt, (1.0 if goal else 0.0), goal


class Robot:
    def __init__(self, seed):
        self.rng = random.Random(seed)
        self.places = ["table"] * 3
        self.step = 0
        self.total = 0.0
        self.reset_next = False
        self.queued = None  # takeover action

    def holding(self):
        return "hand" in self.places

    def next_step(self, budget_left):
        self.step += 1
        state = name(self.places)
        if self.reset_next:
            self.reset_next = False
            self.places = ["table"] * 3
            return self.row(state, None, "reset", 0.0, False, "none", budget_left)
        if self.queued is not None:
            action, actor, event = self.queued, "human", "takeover"
            self.queued = None
        else:
            if self.holding():
                held = self.places.index("hand")
                action = 3 + held if self.rng.random() < 0.6 else self.rng.choice([3, 4, 5, 6])
            else:
                action = self.rng.choice([c for c in range(3) if self.places[c] != PLACES[c]] or [0])
            actor, event = self.rng.choice(["mf", "mb", "mix"]), "none"
        self.places, reward, goal = apply(self.places, action)
        self.total += reward
        if goal:
            self.reset_next = True
        return self.row(state, action, actor, reward, goal, event, budget_left)

    def row(self, state, action, actor, reward, terminal, event, budget_left):
        return {"type": "step", "step": self.step, "state": state, "action": action,
                "actor": actor, "next_state": name(self.places), "reward": reward,
                "total_reward": self.total, "terminal": terminal, "event": event,
                "budget_left": budget_left, "holding": self.holding()}


def parse(text):
    """The request, or raises ValueError with the reason."""
    if len(text.encode()) >= MAX_MESSAGE:
        raise ValueError(f"message of {len(text.encode())} bytes")
    m = json.loads(text)
    if not isinstance(m, dict):
        raise ValueError("not an object")
    fields = {"consent": set(), "pause": set(), "resume": set(), "stop": set(),
              "pace": {"ms"}, "feedback": {"step", "sign"}, "takeover": {"to"}}
    kind = m.get("type")
    if kind not in fields:
        raise ValueError(f"unknown type {kind!r}")
    if set(m) - {"type"} != fields[kind]:
        raise ValueError(f"fields {sorted(m)} for {kind}")
    if kind == "pace" and not (type(m["ms"]) is int and 100 <= m["ms"] <= 5000):
        raise ValueError(f"pace {m['ms']!r}")
    if kind == "feedback" and not (type(m["step"]) is int and m["step"] >= 1 and m["sign"] in (1, -1)
                                   and type(m["sign"]) is int):
        raise ValueError(f"feedback {m!r}")
    if kind == "takeover" and m["to"] not in ("red", "green", "blue", "table"):
        raise ValueError(f"takeover to {m['to']!r}")
    return m


class Server:
    def __init__(self, args):
        self.args = args
        self.count = 0

    def log_message(self, session, m):
        if self.args.log:
            with open(self.args.log, "a") as f:
                f.write(json.dumps({"session": session, "message": m}) + "\n")

    def process_request(self, connection, request):
        path = request.path.split("?")[0]
        if path == "/ws":
            return None
        if path != "/":
            return connection.respond(http.HTTPStatus.NOT_FOUND, "not found\n")
        response = connection.respond(http.HTTPStatus.OK, PAGE.read_text())
        del response.headers["Content-Type"]
        response.headers["Content-Type"] = "text/html; charset=utf-8"
        response.headers["Content-Security-Policy"] = CSP
        response.headers["Cache-Control"] = "no-store"
        return response

    async def handler(self, ws):
        self.count += 1
        n = self.count
        participant, session = f"p-{n:04x}", f"s-mock-{n}"
        try:
            if self.args.mode == "view":
                await self.view(ws, participant)
            else:
                await self.teach(ws, participant, session)
        except ConnectionClosed:
            print(f"mock: {session}: tab left", file=sys.stderr)

    async def view(self, ws, participant):
        robot = Robot(7)
        rows = [robot.next_step(None) for _ in range(self.args.steps)]
        for r in rows[5::17]:
            r["event"] = "congratulation"
        for r in rows[9::23]:
            r["event"] = "punishment"
        await ws.send(json.dumps(self.hello("view", participant, None, None) | {"steps": len(rows)}))
        await ws.send(json.dumps({"type": "replay", "rows": rows, "participant": participant}))
        async for _ in ws:
            pass

    def hello(self, mode, participant, session, consent):
        return {"type": "hello", "mode": mode, "task": TASK, "participant": participant,
                "session": session, "consent": consent, "budget": self.args.budget,
                "budget_left": self.args.budget, "steps": self.args.steps,
                "pace_ms": self.args.pace, "actions": ACTIONS}

    async def teach(self, ws, participant, session):
        args = self.args
        budget_left = args.budget
        await ws.send(json.dumps(self.hello("teach", participant,
                                            None if args.consent else session, args.consent)))

        async def bad(why):
            print(f"mock: {session}: closing: {why}", file=sys.stderr)
            await ws.close(1008, why[:100])

        if args.consent:
            while True:
                try:
                    m = parse(await ws.recv())
                except ValueError as e:
                    return await bad(f"malformed message before consent: {e}")
                self.log_message(session, m)
                if m["type"] == "consent":
                    break
                await ws.send(json.dumps({"type": "refused", "reason": "consent first"}))
            await ws.send(json.dumps({"type": "started", "session": session, "participant": participant}))
        robot = Robot(hash(session))
        pace, paused = args.pace / 1000, False
        last = None
        loop = asyncio.get_running_loop()
        next_at = loop.time() + pace
        recv = asyncio.ensure_future(ws.recv())
        try:
            while True:
                timeout = None if paused else max(0.0, next_at - loop.time())
                done, _ = await asyncio.wait({recv}, timeout=timeout)
                if not done:
                    if robot.step >= args.steps:
                        await ws.send(json.dumps({"type": "end", "reason": "finished"}))
                        return await ws.close(1008, "finished")
                    last = robot.next_step(budget_left)
                    await ws.send(json.dumps(last))
                    if args.close_after and robot.step >= args.close_after:
                        return await bad("the server is shutting down")
                    next_at = loop.time() + pace
                    continue
                try:
                    text = recv.result()
                except ConnectionClosed:
                    print(f"mock: {session}: tab closed at step {robot.step}", file=sys.stderr)
                    return
                recv = asyncio.ensure_future(ws.recv())
                if isinstance(text, bytes):
                    return await bad("binary message")
                try:
                    m = parse(text)
                except ValueError as e:
                    return await bad(f"malformed message: {e}")
                self.log_message(session, m)
                kind, reply = m["type"], None
                if kind == "pace":
                    pace = m["ms"] / 1000
                    next_at = min(next_at, loop.time() + pace)
                elif kind == "pause":
                    paused = True
                elif kind == "resume":
                    paused = False
                    next_at = loop.time() + pace
                elif kind == "stop":
                    await ws.send(json.dumps({"type": "end", "reason": "stopped"}))
                    return await ws.close(1008, "stopped")
                elif kind == "takeover":
                    if not robot.holding():
                        reply = {"type": "refused", "reason": "the robot holds no cube"}
                    else:
                        robot.queued = {"red": 3, "green": 4, "blue": 5, "table": 6}[m["to"]]
                elif kind == "feedback":
                    if last is None or m["step"] != last["step"]:
                        reply = {"type": "refused", "reason": f"step {m['step']} is not the last step"}
                    elif last["actor"] in ("human", "reset"):
                        reply = {"type": "refused", "reason": "no feedback on that step"}
                    elif budget_left == 0:
                        reply = {"type": "refused", "reason": "no feedback left"}
                    else:
                        if budget_left is not None:
                            budget_left -= 1
                        event = "congratulation" if m["sign"] > 0 else "punishment"
                        last["event"] = event
                        reply = {"type": "feedback", "step": m["step"], "event": event,
                                 "budget_left": budget_left}
                elif kind == "consent":
                    pass
                if reply:
                    await ws.send(json.dumps(reply))
        finally:
            recv.cancel()


async def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mode", choices=["teach", "view"], default="teach")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=8765)
    p.add_argument("--task", choices=["tidy1", "tidy2", "other"], default="tidy1")
    p.add_argument("--consent", default=None)
    p.add_argument("--budget", type=int, default=None)
    p.add_argument("--pace", type=int, default=1000)
    p.add_argument("--steps", type=int, default=3000)
    p.add_argument("--close-after", type=int, default=0)
    p.add_argument("--log", default=None)
    args = p.parse_args()
    global TASK
    TASK = args.task
    server = Server(args)
    async with serve(server.handler, args.host, args.port, process_request=server.process_request,
                     max_size=MAX_MESSAGE) as s:
        print(f"mock: serving on http://{args.host}:{args.port}/ ({args.mode})", file=sys.stderr, flush=True)
        await s.serve_forever()


if __name__ == "__main__":
    asyncio.run(main())
