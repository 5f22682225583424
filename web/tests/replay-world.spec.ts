// `cart2d replay` of a mission on a ROS map with a simulated world (a box, the camera, perception):
// a panel opened after the replay has ended shows the floor plan, the box, the camera and where the
// cart ended; the replay's bar pauses it, seeks it (the world as it was then) and restarts it.

import { mkdtempSync, mkdirSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

import { expect, type Page, test } from "@playwright/test";

import { type Replay, recordMission, startReplay } from "./replay-helpers";

const COLS = 60; // a 3 x 2 m room at 5 cm, its outline walled (map_server's PGM: 0 occupied, 254 free)
const ROWS = 40;
const LAST_GOAL: [number, number] = [0.4, 0.4];
let dir = "";
let replay: Replay | null = null;

function writeRoom(folder: string): void {
  mkdirSync(folder, { recursive: true });
  const pixels = Buffer.alloc(COLS * ROWS, 254);
  for (let r = 0; r < ROWS; r++) {
    for (let c = 0; c < COLS; c++) {
      if (r === 0 || r === ROWS - 1 || c === 0 || c === COLS - 1) pixels[r * COLS + c] = 0;
    }
  }
  writeFileSync(join(folder, "room.pgm"), Buffer.concat([Buffer.from(`P5\n${COLS} ${ROWS}\n255\n`), pixels]));
  const yaml = "image: room.pgm\nresolution: 0.05\norigin: [-0.5, -0.5, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
  writeFileSync(join(folder, "room.yaml"), yaml);
}

test.beforeAll(async () => {
  test.setTimeout(180_000); // the mission sees: it runs in real time
  dir = mkdtempSync(join(tmpdir(), "cart2d-replay-world-"));
  writeRoom(join(dir, "maps"));
  const box = { x: 1.2, y: 0.9, sx: 0.2, sy: 0.2, height: 0.3, colour: "#3050c0", id: "blue" };
  const mission = { map: "maps/room.yaml", goals: [[1.2, 0.0], LAST_GOAL], world: { boxes: [box] }, timeout_s: 60 };
  replay = await startReplay(recordMission(dir, mission, 150_000), dir, ["--speed", "2"]);
});

test.afterAll(() => {
  replay?.stop();
  rmSync(dir, { recursive: true, force: true });
});

async function control(body: Record<string, unknown>): Promise<{ state: string; duration_s: number }> {
  // the replay's API from outside the page (the page follows it: /ws tells it the state there)
  const answer = await fetch(`${replay?.base}/api/replay`, {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify(body),
  });
  expect(answer.status).toBe(200);
  return (await answer.json()) as { state: string; duration_s: number };
}

/** Milliseconds to wait for a recording of `seconds` played at --speed 2 (1.5 times its time). */
function playedThrough(seconds: number): number {
  return (seconds / 2) * 1.5 * 1000 + 20_000;
}

async function poseNear(page: Page, to: [number, number], tol: number): Promise<void> {
  await expect(async () => {
    const x = Number(await page.locator("#pose-x").getAttribute("data-value"));
    const y = Number(await page.locator("#pose-y").getAttribute("data-value"));
    expect(Math.hypot(x - to[0], y - to[1])).toBeLessThan(tol);
  }).toPass();
}

test("a panel opened after the end sees the floor plan, the box and the camera; pause, seek and restart", async ({ page }) => {
  test.setTimeout(240_000); // it plays the whole recording twice
  // played to its end before any panel opened: at --speed 2, half as long as the mission took on
  // the wall clock (a busy machine stretched it: it ran in lockstep with perception), and a
  // busy machine's pace on top
  const { duration_s: recorded } = await control({ action: "play" });
  await expect(async () => {
    const state = ((await (await fetch(`${replay?.base}/api/replay`)).json()) as { state: string }).state;
    expect(state).toBe("ended");
  }).toPass({ timeout: playedThrough(recorded) });

  await page.goto(`${replay?.base}/`);
  const map = page.locator("#map");
  await expect(map).toHaveAttribute("data-floor-plan", `${COLS}x${ROWS}`);
  await expect(map).toHaveAttribute("data-boxes", "1");
  await expect(page.locator("#mission-state")).toHaveText("arrived");
  await poseNear(page, LAST_GOAL, 0.05);
  await expect(page.locator("#replay-bar")).toHaveAttribute("data-state", "ended");
  await expect(page.locator("#replay-time")).toContainText("(ended)");
  await expect(page.locator("#camera-view")).toBeVisible();
  await expect.poll(() => page.locator("#camera-view").evaluate((img: HTMLImageElement) => img.naturalWidth)).toBeGreaterThan(0);
  for (const hidden of ["#camera-form", "#clear-perceived", "#estop", "#goto-form"]) await expect(page.locator(hidden)).toBeHidden();

  // Seek with the slider: a time the cart drove to the first goal (paused there, the world as it
  // was: the floor plan, the box, the mission driving), then play and pause: it stays where it is
  const slider = page.locator("#replay-seek");
  const bar = page.locator("#replay-bar");
  const end = Number(await slider.getAttribute("max"));
  let driving = -1; // found through the API: the mission at a time, read in steps of 1/40 of it
  for (let k = 1; k < 40 && driving < 0; k++) {
    const t = Number(((end * k) / 40).toFixed(1));
    await control({ action: "seek", position_s: t });
    const status = (await (await fetch(`${replay?.base}/api/status`)).json()) as { mission: { state: string } };
    if (status.mission.state === "driving") driving = t;
  }
  expect(driving).toBeGreaterThan(0);
  await slider.fill("0");
  await expect(page.locator("#mission-state")).toHaveText("idle");
  await slider.fill(String(driving));
  await expect(page.locator("#replay-time")).toContainText(`${driving.toFixed(1)} /`);
  await expect(bar).toHaveAttribute("data-state", "paused");
  await expect(page.locator("#mission-state")).toHaveText("driving");
  await expect(map).toHaveAttribute("data-boxes", "1");
  await expect(map).toHaveAttribute("data-floor-plan", `${COLS}x${ROWS}`);
  const play = page.locator("#replay-play");
  await play.click();
  await expect(bar).toHaveAttribute("data-state", "playing");
  await expect(play).toHaveText("Pause");
  await play.click();
  await expect(bar).toHaveAttribute("data-state", "paused");
  await expect(play).toHaveText("Play");
  const at = await bar.getAttribute("data-position");
  const x = await page.locator("#pose-x").getAttribute("data-value");
  await page.waitForTimeout(600);
  expect(await bar.getAttribute("data-position")).toBe(at);
  expect(await page.locator("#pose-x").getAttribute("data-value")).toBe(x);

  // to the end (where the cart arrived), back to the start (no mission yet), and restart
  await slider.fill(String(end));
  await expect(page.locator("#mission-state")).toHaveText("arrived");
  await poseNear(page, LAST_GOAL, 0.05);
  await slider.fill("0.5");
  await expect(page.locator("#mission-state")).toHaveText("idle");
  await expect(page.locator("#replay-time")).toContainText("0.5 /");
  await page.locator("#replay-restart").click();
  await expect(bar).toHaveAttribute("data-state", /playing|ended/);
  // the whole recording again at --speed 2: as long as the mission took on the wall clock, which
  // a busy machine stretches (the recorded mission ran in lockstep with perception)
  await expect(page.locator("#mission-state")).toHaveText("arrived", { timeout: playedThrough(end) });
});
