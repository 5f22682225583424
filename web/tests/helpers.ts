// What the panel's browser tests share: the gateway and simulator they run against (started by
// global-setup.ts), opening the panel and watching it, the map's transform, the robot's pose,
// and moving the robot where a test needs it.

import { mkdirSync } from "node:fs";
import { resolve } from "node:path";
import { expect, type APIRequestContext, type Page } from "@playwright/test";

import { simControl } from "./gateway";

export const BASE = process.env["CART2D_URL"] ?? "";
export const SIM = process.env["CART2D_SIM_CONTROL"] ?? ""; // the simulator's side channel
export const SHOTS = resolve(import.meta.dirname, "..", "..", "build", "screenshots");
mkdirSync(SHOTS, { recursive: true });

export type Point = [number, number];

export interface Watched {
  consoleErrors: string[];
  pageErrors: string[];
  requests: string[];
}

export async function open(page: Page): Promise<Watched> {
  const watched: Watched = { consoleErrors: [], pageErrors: [], requests: [] };
  page.on("console", (m) => {
    if (m.type() === "error") watched.consoleErrors.push(m.text());
  });
  page.on("pageerror", (e) => watched.pageErrors.push(String(e)));
  page.on("request", (r) => {
    if (r.method() !== "GET") watched.requests.push(`${r.method()} ${new URL(r.url()).pathname}`);
  });
  await page.goto(`${BASE}/`);
  await expect(page.locator("body")).toHaveAttribute("data-link", "connected");
  await expect(page.locator("#pose-x")).toHaveAttribute("data-value", /\d/);
  await expect(page.locator("#map")).toHaveAttribute("data-scale", /\d/);
  // the simulator-faults form appears (or stays hidden) once its GET is answered: the page's
  // layout is final from then on
  await expect(page.locator("#sim-faults")).toHaveAttribute("data-loaded", "true");
  return watched;
}

/** The map's CSS-pixel position of world point p, from the transform the canvas publishes. */
export async function screenOf(page: Page, p: Point): Promise<Point> {
  const d = await page.locator("#map").evaluate((c: HTMLElement) => ({ ...c.dataset }));
  const scale = Number(d["scale"]);
  return [Number(d["originX"]) + p[0] * scale, Number(d["originY"]) - p[1] * scale];
}

export async function pixel(page: Page, p: Point): Promise<number[]> {
  const [x, y] = await screenOf(page, p);
  return page.locator("#map").evaluate(
    (c: HTMLCanvasElement, [px, py]: Point) => {
      const dpr = window.devicePixelRatio || 1;
      const ctx = c.getContext("2d");
      return ctx ? Array.from(ctx.getImageData(Math.round(px * dpr), Math.round(py * dpr), 1, 1).data) : [];
    },
    [x, y] as Point,
  );
}

export async function clickMap(page: Page, p: Point): Promise<void> {
  const [x, y] = await screenOf(page, p);
  await page.locator("#map").click({ position: { x, y } });
}

export async function pose(page: Page): Promise<Point> {
  const x = Number(await page.locator("#pose-x").getAttribute("data-value"));
  const y = Number(await page.locator("#pose-y").getAttribute("data-value"));
  return [x, y];
}

export async function obstacles(page: Page): Promise<Point[]> {
  const r = await page.request.get(`${BASE}/api/map`);
  return ((await r.json()) as { obstacles: Point[] }).obstacles;
}

export const near = (a: Point, b: Point, tol = 1e-6): boolean => Math.hypot(a[0] - b[0], a[1] - b[1]) <= tol;

export async function driveAway(page: Page, to: Point): Promise<void> {
  await page.fill("#goto-form input[name=x]", String(to[0]));
  await page.fill("#goto-form input[name=y]", String(to[1]));
  await page.click("#goto-form button[type=submit]");
  await expect(page.locator("body")).toHaveAttribute("data-mission", "driving");
  // moving: the odometry readout changes
  const start = await pose(page);
  await expect.poll(async () => Math.hypot(...((await pose(page)).map((v, k) => v - (start[k] ?? 0)) as Point))).toBeGreaterThan(0.05);
}

export async function expectHalted(page: Page): Promise<void> {
  await expect(page.locator("body")).toHaveAttribute("data-mission", "failed");
  await expect(page.locator("#mission-detail")).toContainText("stopped by the user");
  await page.waitForTimeout(400); // the last of the braking
  const a = await pose(page);
  await page.waitForTimeout(1000);
  const b = await pose(page);
  expect(Math.hypot(a[0] - b[0], a[1] - b[1])).toBeLessThan(0.003);
  const status = await (await page.request.get(`${BASE}/api/status`)).json();
  expect(status.status.mode).not.toBe("PATH");
}

export interface Setting {
  id: number;
  name: string;
  unit: string;
  min: number;
  max: number;
  doc: string;
  value: number;
}

export async function settings(page: Page): Promise<Setting[]> {
  return (await (await page.request.get(`${BASE}/api/firmware/settings`)).json()) as Setting[];
}

export async function setting(page: Page, name: string): Promise<number> {
  const s = (await settings(page)).find((x) => x.name === name);
  if (!s) throw new Error(`no firmware setting ${name}`);
  return s.value;
}

export async function gotoAndWait(page: Page, p: Point): Promise<void> {
  const r = await page.request.post(`${BASE}/api/goto`, { data: { x: p[0], y: p[1] } });
  expect(r.ok()).toBe(true);
  await expect
    .poll(
      async () => {
        const m = (await (await page.request.get(`${BASE}/api/mission`)).json()) as { state: string; goal: Point | null };
        return m.state === "arrived" && m.goal !== null && near(m.goal, p, 1e-3);
      },
      { timeout: 20_000 },
    )
    .toBe(true);
}

export interface TruePose {
  x: number;
  y: number;
  theta: number;
}

export async function truePose(): Promise<TruePose> {
  return (await simControl(SIM, { type: "truth" }))["truth"] as TruePose;
}

/** The reset button of the simulated Nano, as a fault: nothing the gateway asked for. */
export async function pressReset(page: Page): Promise<void> {
  const before = ((await (await page.request.get(`${BASE}/api/status`)).json()) as { reset: { noticed: number } }).reset.noticed;
  await simControl(SIM, { type: "reset" });
  await expect
    .poll(async () => ((await (await page.request.get(`${BASE}/api/status`)).json()) as { reset: { noticed: number } }).reset.noticed)
    .toBe(before + 1);
}

/** A protocol command through the API (what the command form sends); its reply. */
export async function command(page: Page, name: string, args: number[] = []): Promise<{ status: string; results: number[] }> {
  const r = await page.request.post(`${BASE}/api/command`, { data: { name, args } });
  expect(r.ok()).toBe(true);
  return (await r.json()) as { status: string; results: number[] };
}

/** Makes the gateway plan from the pose it has, if an earlier test left it untrusted (the
 * firmware update of panel.spec.ts restarts the controller): so a file's tests start as a user
 * who has dealt with the restart notice. */
export async function trustPose(request: APIRequestContext): Promise<void> {
  const status = (await (await request.get(`${BASE}/api/status`)).json()) as { pose_trust: { trusted: boolean } };
  if (status.pose_trust.trusted) return;
  // a change in JSON, bodiless too (the gateway's guards, SECURITY.md)
  const r = await request.post(`${BASE}/api/pose/accept`, { headers: { "Content-Type": "application/json" } });
  expect(r.ok(), await r.text()).toBe(true);
}

/** Drives the cart to (x, 0.8) facing east, `gap` metres short of where its front switches
 * touch the east wall (x = 1.88 for its centre); through the API, so it needs no simulator
 * side channel (whose address a restarted simulator changes). */
export async function faceEastWall(page: Page, gap: number): Promise<void> {
  const contactX = 1.88;
  await gotoAndWait(page, [contactX - gap - 0.4, 0.8]);
  await gotoAndWait(page, [contactX - gap, 0.8]); // the last segment heads east
}
