// Attacks from web pages in Chromium on a gateway of their own (issue 11, SECURITY.md): a page on
// another origin that tries every state-changing route with the requests a browser sends without
// asking (no-cors fetches, forms, beacons, pings), and a DNS-rebinding page (a foreign name that
// resolves to 127.0.0.1) whose script calls the API as its own origin. Nothing may change: the
// firmware (no restart, no update), the map, settings.json, the cart's true pose; no telemetry leaks.

import { existsSync, readFileSync } from "node:fs";
import { createServer, type Server } from "node:http";
import { join, resolve } from "node:path";
import { chromium, expect, test } from "@playwright/test";

import { simControl, startGateway, type Gateway } from "./gateway";

const HEX = readFileSync(resolve(import.meta.dirname, "..", "..", "build", "firmware", "cart2d-nano.hex"), "utf8");
// wipes the map and opens the gateway on every interface at its next start
const SETTINGS = JSON.stringify({ version: 1, network: { host: "0.0.0.0", port: 8080 }, map: { cols: 10, rows: 10, step_m: 0.2, obstacles: [] } });

// Every state-changing route (tests/server/test_web_guards.py checks this list against /openapi.json).
const ROUTES: [string, string, string][] = [
  ["POST", "/api/firmware/update", HEX],
  ["POST", "/api/settings/file", SETTINGS],
  ["PUT", "/api/settings/network", '{"host": "0.0.0.0", "port": 8080}'],
  ["POST", "/api/reset", ""],
  ["POST", "/api/firmware/save", ""],
  ["POST", "/api/firmware/load", ""],
  ["PUT", "/api/firmware/settings", '{"id": 6, "value": 0.3}'],
  ["PUT", "/api/map/obstacle", '{"x": 1.0, "y": 1.0}'],
  ["DELETE", "/api/map/obstacles", ""],
  ["POST", "/api/pose", '{"x": 0.5, "y": 0.5, "theta": 1.0}'],
  ["POST", "/api/pose/accept", ""],
  ["POST", "/api/pose/reset-routine", ""],
  ["POST", "/api/command", '{"name": "GOTO", "args": [1.0, 0.0]}'],
  ["POST", "/api/goto", '{"x": 1.0, "y": 0.0}'],
  ["POST", "/api/drive", '{"v": 0.3, "omega": 0.0}'],
  ["POST", "/api/stop", ""],
  ["PUT", "/api/sim/faults", '{"uart_rx_drop": 1}'],
  ["POST", "/api/sim/boxes", '{"boxes": [{"x": 0.6, "y": 0.0, "sx": 0.2, "sy": 0.6}]}'],
  ["DELETE", "/api/sim/boxes/box-1", ""],
  ["DELETE", "/api/sim/boxes", ""],
  ["PUT", "/api/perception", '{"enabled": false, "cells": [[1.0, 0.0, 1.0], [1.0, 0.2, 1.0]]}'],
  ["POST", "/api/perception/clear", ""],
  ["PUT", "/api/settings/camera", '{"stream_url": "http://127.0.0.1:9/stream"}'],
];

interface Snapshot {
  map: unknown;
  perception: unknown;
  settingsFile: string | null;
  firmwareUpdate: string;
  restartsNoticed: number;
  mission: string;
  firmwareSettings: unknown;
  simFaults: unknown;
  simWorld: unknown;
  truePose: number[];
  simTime: number;
}

async function snapshot(gw: Gateway): Promise<Snapshot> {
  const get = async (path: string): Promise<unknown> => (await fetch(`${gw.base}${path}`)).json();
  const status = (await get("/api/status")) as { reset: { noticed: number }; mission: { state: string } };
  // a firmware update (avrdude through Optiboot) resets the MCU; the side channel may not answer then
  const truth = await simControl(gw.simulator(), { type: "truth" }).then(
    (ack) => ack["truth"] as Record<string, number>,
    (): Record<string, number> => ({ t: -1 }),
  );
  const file = join(gw.home, "settings.json");
  return {
    map: await get("/api/map"),
    perception: await get("/api/perception"),
    settingsFile: existsSync(file) ? readFileSync(file, "utf8") : null,
    firmwareUpdate: ((await get("/api/firmware/update")) as { state: string }).state,
    restartsNoticed: status.reset.noticed,
    mission: status.mission.state,
    firmwareSettings: await get("/api/firmware/settings"),
    simFaults: await get("/api/sim/faults"),
    simWorld: ((await get("/api/sim/world")) as { boxes: unknown }).boxes,
    truePose: ["x", "y", "theta"].map((k) => Math.round((truth[k] ?? NaN) * 1e4) / 1e4),
    simTime: truth["t"] ?? NaN,
  };
}

function expectUnchanged(before: Snapshot, after: Snapshot): void {
  const { simTime: t0, ...rest0 } = before;
  const { simTime: t1, ...rest1 } = after;
  expect(rest1).toEqual(rest0);
  expect(t1).toBeGreaterThan(t0); // the same simulator: a new firmware would restart it from t = 0
}

// The attacker's page: every route, every request a page can send to another origin unasked.
function attackPage(gateway: string): string {
  const script = `
const GW = ${JSON.stringify(gateway)};
const ROUTES = ${JSON.stringify(ROUTES)};
const log = [];
let frames = 0;
const wait = (ms) => new Promise((ok) => setTimeout(ok, ms));
async function attempt(label, send) {
  try { await send(); log.push(label + ": sent"); } catch (e) { log.push(label + ": " + e); }
}
function form(url, enctype, fields, file) {
  return new Promise((ok) => {
    const frame = document.createElement("iframe");
    frame.name = "sink" + frames++;
    document.body.append(frame);
    const f = document.createElement("form");
    Object.assign(f, { method: "POST", action: url, enctype, target: frame.name });
    for (const [name, value] of fields) {
      const input = document.createElement("input");
      Object.assign(input, { type: "hidden", name, value });
      f.append(input);
    }
    if (file) {
      const input = document.createElement("input");
      input.type = "file";
      input.name = "file";
      const dt = new DataTransfer();
      dt.items.add(new File([file], "payload.hex", { type: "application/octet-stream" }));
      input.files = dt.files;
      f.append(input);
    }
    document.body.append(f);
    frame.addEventListener("load", () => ok(), { once: true });
    setTimeout(ok, 3000);
    f.submit();
  });
}
// enctype text/plain writes name=value: a JSON body whose last string swallows the "="
function jsonAsTextPlain(body) {
  if (!body.startsWith("{")) return [[body, ""]];
  return [[body.slice(0, -1) + ', "token": "', 'xxxxxxxxxxxxxxxxxxxxxxxx"}']];
}
async function run() {
  const ws = new WebSocket(GW.replace("http", "ws") + "/ws");
  let wsMessages = 0;
  ws.onmessage = () => wsMessages++;
  for (const [method, path, body] of ROUTES) {
    const url = GW + path;
    const tag = method + " " + path;
    await attempt(tag + " no-cors text/plain", () => fetch(url, { method, mode: "no-cors", headers: { "Content-Type": "text/plain" }, body }));
    await attempt(tag + " no-cors untyped blob", () => fetch(url, { method, mode: "no-cors", body: new Blob([body]) }));
    await attempt(tag + " no-cors urlencoded", () => fetch(url, { method, mode: "no-cors", body: new URLSearchParams({ data: body }) }));
    await attempt(tag + " no-cors multipart", () => { const d = new FormData(); d.append("file", new Blob([body]), "payload.hex"); return fetch(url, { method, mode: "no-cors", body: d }); });
    await attempt(tag + " no-cors bodiless", () => fetch(url, { method, mode: "no-cors" }));
    await attempt(tag + " cors json", () => fetch(url, { method, headers: { "Content-Type": "application/json" }, body: body || "{}" }));
    await attempt(tag + " beacon text", () => { if (!navigator.sendBeacon(url, body)) throw new Error("not queued"); });
    await attempt(tag + " beacon json", () => { if (!navigator.sendBeacon(url, new Blob([body], { type: "application/json" }))) throw new Error("not queued"); });
    await attempt(tag + " beacon empty", () => { if (!navigator.sendBeacon(url)) throw new Error("not queued"); });
    if (method === "POST") {
      await attempt(tag + " form text/plain", () => form(url, "text/plain", jsonAsTextPlain(body)));
      await attempt(tag + " form urlencoded", () => form(url, "application/x-www-form-urlencoded", [["data", body]]));
      await attempt(tag + " form multipart", () => form(url, "multipart/form-data", [], body));
      await attempt(tag + " ping", () => {
        const a = document.createElement("a");
        a.href = "/sink";
        a.ping = url;
        a.target = "pinged" + frames++;
        document.body.append(a);
        a.click();
      });
    }
  }
  await wait(2000); // beacons and pings leave on their own
  ws.close();
  document.body.dataset.wsMessages = String(wsMessages);
  document.body.dataset.attempts = String(log.length);
  document.body.dataset.done = "1";
}
run();
`;
  return `<!doctype html><html><head><meta charset="utf-8"><title>not the cart</title></head><body><script>${script}</script></body></html>`;
}

function serve(page: string): Promise<{ server: Server; base: string }> {
  const server = createServer((req, res) => {
    if (req.url === "/attack.html") {
      res.writeHead(200, { "Content-Type": "text/html; charset=utf-8" });
      res.end(page);
    } else {
      res.writeHead(204);
      res.end();
    }
  });
  return new Promise((ok) => {
    server.listen(0, "127.0.0.1", () => {
      const address = server.address();
      const port = typeof address === "object" && address ? address.port : 0;
      ok({ server, base: `http://127.0.0.1:${port}` });
    });
  });
}

test("a page on another origin changes nothing, whatever it sends", async ({ page }) => {
  test.setTimeout(120_000);
  const gateway = await startGateway("127.0.0.1", "cart2d-attack-");
  await gateway.waitConnected();
  const attacker = await serve(attackPage(gateway.base));
  try {
    const before = await snapshot(gateway);
    await page.goto(`${attacker.base}/attack.html`);
    await expect(page.locator("body")).toHaveAttribute("data-done", "1", { timeout: 90_000 });
    expect(Number(await page.locator("body").getAttribute("data-attempts"))).toBeGreaterThan(ROUTES.length * 9);
    expect(await page.locator("body").getAttribute("data-ws-messages")).toBe("0");
    await page.waitForTimeout(1000); // a drive or a goal would have moved the cart by now
    expectUnchanged(before, await snapshot(gateway));
  } finally {
    attacker.server.close();
    await gateway.stop();
  }
});

test("a DNS-rebinding page (a foreign name for 127.0.0.1) can neither read nor change anything", async () => {
  test.setTimeout(90_000);
  const gateway = await startGateway("127.0.0.1", "cart2d-rebind-");
  const port = new URL(gateway.base).port;
  // evil.example resolves to 127.0.0.1: the name's owner answered the page's first lookup with its
  // own server, then rebound it. The page's script runs in the origin http://evil.example:PORT.
  const browser = await chromium.launch({
    executablePath: process.env["CHROMIUM"] ?? "/usr/bin/chromium",
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--host-resolver-rules=MAP evil.example 127.0.0.1"],
  });
  try {
    await gateway.waitConnected();
    const before = await snapshot(gateway);
    const page = await browser.newPage();
    const first = await page.goto(`http://evil.example:${port}/`);
    expect(first?.status()).toBe(421);
    const seen = await page.evaluate(async (routes: [string, string, string][]) => {
      const statuses: Record<string, number> = {};
      for (const path of ["/api/status", "/api/map", "/api/settings", "/openapi.json"]) {
        statuses[`GET ${path}`] = (await fetch(path)).status;
      }
      for (const [method, path, body] of routes) {
        const type = path === "/api/firmware/update" ? "application/octet-stream" : "application/json";
        const r = await fetch(path, { method, headers: { "Content-Type": type }, body: method === "GET" ? null : body });
        statuses[`${method} ${path}`] = r.status;
      }
      const ws = await new Promise<{ opened: boolean; messages: number }>((ok) => {
        const socket = new WebSocket(`ws://${location.host}/ws`);
        let opened = false;
        let messages = 0;
        socket.onopen = () => (opened = true);
        socket.onmessage = () => messages++;
        socket.onerror = () => ok({ opened, messages });
        setTimeout(() => {
          socket.close();
          ok({ opened, messages });
        }, 3000);
      });
      return { statuses, ws };
    }, ROUTES);
    expect(Object.keys(seen.statuses)).toHaveLength(ROUTES.length + 4);
    for (const [request, status] of Object.entries(seen.statuses)) expect(status, request).toBe(421);
    expect(seen.ws).toEqual({ opened: false, messages: 0 });
    await new Promise((r) => setTimeout(r, 1000));
    expectUnchanged(before, await snapshot(gateway));
    // the gateway's own name still works in the same browser
    const own = await browser.newPage();
    expect((await own.goto(`${gateway.base}/api/status`))?.status()).toBe(200);
  } finally {
    await browser.close();
    await gateway.stop();
  }
});
