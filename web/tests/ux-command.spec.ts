// The generic-command form as a new user meets it (issue 12): replies in words, an earlier reply
// never left beside a new error, setting names where ids are expected, every command described.

import { readFileSync } from "node:fs";
import { resolve } from "node:path";
import { expect, test, type Page } from "@playwright/test";

import { BASE, open, settings, trustPose } from "./helpers";

test.describe.configure({ mode: "serial" });
test.beforeAll(({ request }) => trustPose(request));

const PROTOCOL = readFileSync(resolve(import.meta.dirname, "..", "..", "docs", "protocol.md"), "utf8");

/** A table of docs/protocol.md by its first header cell: rows of cells (read here on its own,
 * so the test does not lean on the panel's parser). */
function table(first: string): string[][] {
  const lines = PROTOCOL.split("\n");
  const at = lines.findIndex((l) => l.startsWith(`| ${first} |`));
  const rows: string[][] = [];
  for (let k = at + 2; k < lines.length && (lines[k] ?? "").startsWith("|"); k++) {
    rows.push((lines[k] ?? "").split("|").slice(1, -1).map((c) => c.trim()));
  }
  return rows;
}

async function send(page: Page, name: string, args: string[]): Promise<void> {
  await page.selectOption("#cmd-name", name);
  for (let k = 0; k < 4; k++) {
    const input = page.locator(`#cmd-form input[name=a${k}]`);
    if (await input.isEnabled()) await input.fill(args[k] ?? "");
  }
  await page.click("#cmd-form button[type=submit]");
}

test("a refusal's reason is shown in words, not as the command's result", async ({ page }) => {
  const w = await open(page);
  await send(page, "TOL_SET", ["2"]);
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_ERROR");
  const results = page.locator("#cmd-results");
  const [, name, meaning] = table("reason").find((r) => r[0] === "3") ?? [];
  await expect(results).toContainText(`${name}`);
  await expect(results).toContainText(`${meaning}`);
  await expect(results).not.toContainText("tol_rho = 3");
  await expect(page.locator("#cmd-sent")).toHaveText("TOL_SET 2");
  expect(w.pageErrors).toEqual([]);
});

test("a reply on screen is cleared when the next command is refused in the page", async ({ page }) => {
  const w = await open(page);
  await send(page, "POSE", []);
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#cmd-results")).toContainText("x = ");
  await send(page, "GOTO", ["0.4", ""]);
  await expect(page.locator("#cmd-msg")).toHaveText(/empty/);
  await expect(page.locator("#cmd-status")).toHaveText("–");
  await expect(page.locator("#cmd-results")).toHaveText("–");
  await expect(page.locator("#cmd-message")).toHaveText("–");
  expect(w.requests).toEqual(["POST /api/command"]); // the POSE only
});

test("a setting's name is taken wherever a setting id is expected", async ({ page }) => {
  const w = await open(page);
  const all = await settings(page);
  const aMax = all.find((s) => s.name === "a_max_mps2");
  if (!aMax) throw new Error("no a_max_mps2");
  const sent: unknown[] = [];
  page.on("request", (r) => {
    if (r.method() === "POST" && new URL(r.url()).pathname === "/api/command") sent.push(r.postDataJSON());
  });
  await expect(page.locator("#setting-names option")).toHaveCount(all.length);
  await send(page, "PARAM_GET", ["a_max_mps2"]);
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#cmd-results")).toContainText(`id = ${aMax.id} (a_max_mps2)`);
  await expect(page.locator("#cmd-results")).toContainText(`value = ${aMax.value}`);
  expect(sent).toEqual([{ name: "PARAM_GET", args: [aMax.id] }]);

  // PARAM_SET by name, to the value it has: nothing changes
  await send(page, "PARAM_SET", ["a_max_mps2", String(aMax.value)]);
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  await expect(page.locator("#cmd-results")).toContainText("(a_max_mps2)");
  expect(sent[1]).toEqual({ name: "PARAM_SET", args: [aMax.id, aMax.value] });

  // a name that is no setting's: said so in the page, nothing sent
  await send(page, "PARAM_GET", ["a_max"]);
  await expect(page.locator("#cmd-msg")).toContainText("neither a setting's id nor its name: “a_max”");
  await expect(page.locator("#cmd-msg")).toContainText("a_max_mps2");
  await expect(page.locator("#cmd-msg")).not.toContainText("needs 1 argument");
  await page.waitForTimeout(200);
  expect(sent).toHaveLength(2);
  expect(w.pageErrors).toEqual([]);
});

test("every command is described from the protocol's table", async ({ page }) => {
  await open(page);
  const rows = table("code");
  const offered = await page.locator("#cmd-name option").evaluateAll((os) => os.map((o) => (o as HTMLOptionElement).value));
  expect(offered.length).toBeGreaterThan(20);
  for (const name of offered) {
    const row = rows.find((r) => r[1] === `COMMAND_${name}`);
    if (!row) throw new Error(`${name} is not in docs/protocol.md`);
    const notes = (row[4] ?? "").replace(/`/g, "");
    expect(notes, `docs/protocol.md describes ${name}`).not.toBe("");
    await page.selectOption("#cmd-name", name);
    // the table's words, the first letter a capital
    await expect(page.locator("#cmd-doc")).toHaveText(`${notes.charAt(0).toUpperCase()}${notes.slice(1)}.`);
  }
});

test("STATUS is decoded: the mode and flags by name, the reset causes, no float32 noise", async ({ page }) => {
  const w = await open(page);
  await send(page, "STATUS", []);
  await expect(page.locator("#cmd-status")).toHaveText("CONTROL_OK");
  const status = ((await (await page.request.get(`${BASE}/api/status`)).json()) as { status: { mode: string; flags: string[] } }).status;
  const results = page.locator("#cmd-results");
  await expect(results).toContainText(new RegExp(`mode = \\d+ \\(${status.mode}: `));
  const flags = (await results.locator("li", { hasText: "flags = " }).textContent()) ?? "";
  for (const flag of status.flags) expect(flags).toContain(flag);
  await expect(results).toContainText(/reset_cause = \d+: [A-Z_]+/);
  await expect(results).toContainText(/settings_source = \d: (EEPROM|defaults)/);

  // a float32 is shown as the number it stands for: TOL_GET's 0.005 is not 0.004999999888241291
  const tol = (await settings(page)).find((s) => s.name === "tol_final_m");
  if (!tol) throw new Error("no tol_final_m");
  // the API gives a float32 in its shortest digits too (cart2d/link/protocol.py): 0.005
  expect(String(tol.value).length).toBeLessThanOrEqual(7);
  await send(page, "TOL_GET", []);
  await expect(results).toHaveText(/^tol_rho = [\d.]+$/);
  const shown = ((await results.textContent()) ?? "").replace("tol_rho = ", "");
  expect(shown.length).toBeLessThanOrEqual(7); // "0.005", not "0.004999999888241291"
  expect(Math.abs(Number(shown) - tol.value)).toBeLessThan(1e-7);
  expect(w.pageErrors).toEqual([]);
});
