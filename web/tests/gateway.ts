// A real `cart2d sim` for the browser tests: the simulator and the gateway serving the built
// panel, on a free port with a fresh CART2D_HOME, without the simulated camera unless asked;
// stopped gracefully (SIGINT, then SIGKILL).

import { type ChildProcess, spawn } from "node:child_process";
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { createConnection, createServer } from "node:net";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";

export const ROOT = resolve(import.meta.dirname, "..", "..");

export interface Gateway {
  base: string; // http://127.0.0.1:<port>
  home: string; // its CART2D_HOME (settings.json, the simulator's EEPROM)
  output: () => string; // what it printed so far (stdout and stderr)
  simulator: () => string; // the simulator's side channel, host:port (once it runs)
  waitConnected: (timeoutMs?: number) => Promise<void>;
  stop: () => Promise<void>;
}

export function freePort(): Promise<number> {
  return new Promise((ok, fail) => {
    const server = createServer();
    server.once("error", fail);
    server.listen(0, "127.0.0.1", () => {
      const address = server.address();
      const port = typeof address === "object" && address ? address.port : 0;
      server.close(() => ok(port));
    });
  });
}

/** A free port whose next one is free too (the simulated ESP32-CAM's, its stream on port + 1). */
async function freePortPair(): Promise<number> {
  for (;;) {
    const port = await freePort();
    if (port >= 65535) continue;
    const free = await new Promise<boolean>((ok) => {
      const server = createServer();
      server.once("error", () => ok(false));
      server.listen(port + 1, "127.0.0.1", () => server.close(() => ok(true)));
    });
    if (free) return port;
  }
}

export async function stopChild(child: ChildProcess): Promise<void> {
  const exited = new Promise<void>((ok) => {
    if (child.exitCode !== null) ok();
    else child.once("exit", () => ok());
  });
  child.kill("SIGINT");
  const timer = setTimeout(() => child.kill("SIGKILL"), 5000);
  await exited;
  clearTimeout(timer);
}

export interface GatewayOptions {
  /** The simulated camera and perception on every frame (off unless asked: the other specs do
   * not look, and it costs the loaded test machine a core). */
  camera?: boolean;
  /** Run in its CART2D_HOME before the gateway starts (a camera calibration saved there). */
  prepare?: (home: string) => Promise<void>;
}

// Starts `cart2d sim --speed 1` bound to `host` (127.0.0.1 unless given), with `extra` options.
export async function startGateway(
  host = "127.0.0.1",
  prefix = "cart2d-panel-",
  extra: string[] = [],
  options: GatewayOptions = {},
): Promise<Gateway> {
  const cart2d = join(ROOT, "build", "venv", "bin", "cart2d");
  if (!existsSync(cart2d)) throw new Error(`${cart2d} is missing: run make python-env sim firmware`);
  const home = mkdtempSync(join(tmpdir(), prefix));
  await options.prepare?.(home);
  const port = await freePort();
  let output = "";
  const args = ["sim", "--speed", "1", "--host", host, "--port", String(port), ...extra];
  // the simulated camera on ports of its own: its default (8180) may be another gateway's
  if (options.camera) args.push("--camera-port", String(await freePortPair()));
  else args.push("--no-camera");
  const child = spawn(cart2d, args, {
    cwd: ROOT,
    env: { ...process.env, CART2D_HOME: home },
    stdio: ["ignore", "pipe", "pipe"],
  });
  child.stdout?.on("data", (d: Buffer) => (output += d.toString()));
  child.stderr?.on("data", (d: Buffer) => (output += d.toString()));
  const base = `http://127.0.0.1:${port}`;

  // Until GET /api/status (allowed without a token) says the robot is connected and answering.
  const waitConnected = async (timeoutMs = 30_000): Promise<void> => {
    const deadline = Date.now() + timeoutMs;
    while (Date.now() < deadline) {
      try {
        const r = await fetch(`${base}/api/status`);
        if (r.ok) {
          const s = (await r.json()) as { link: { state: string }; pose?: unknown };
          if (s.link.state === "connected" && s.pose) return;
        }
      } catch {
        /* not listening yet */
      }
      await new Promise((r) => setTimeout(r, 200));
    }
    throw new Error(`cart2d sim did not come up at ${base}:\n${output}`);
  };

  const stop = async (): Promise<void> => {
    await stopChild(child);
    rmSync(home, { recursive: true, force: true });
  };
  const simulator = (): string => /side channel (\S+)/.exec(output)?.[1] ?? "";
  return { base, home, output: () => output, simulator, waitConnected, stop };
}

/** One message to the simulator's side channel (sim/README.md); resolves with its ack. What
 * the tests do to the robot that the panel cannot: the reset button, placing the cart. */
/** tests/support/mjpeg_server.py, an MJPEG server like the ESP32-CAM's, with `args` (frame interval,
 * size); its stream's URL once it serves. */
export function startTestCamera(args: string[]): Promise<{ child: ChildProcess; url: string }> {
  const python = join(ROOT, "build", "venv", "bin", "python");
  const child = spawn(python, ["-m", "tests.support.mjpeg_server", ...args], { cwd: ROOT, stdio: ["ignore", "pipe", "inherit"] });
  return new Promise((ok, fail) => {
    const timer = setTimeout(() => fail(new Error("the test camera did not start")), 10_000);
    child.stdout?.once("data", (d: Buffer) => {
      clearTimeout(timer);
      ok({ child, url: d.toString().trim() });
    });
  });
}

export function simControl(address: string, message: Record<string, unknown>): Promise<Record<string, unknown>> {
  const [host, port] = address.split(":");
  const id = Math.floor(Math.random() * 1e9);
  return new Promise((ok, fail) => {
    const socket = createConnection({ host: host ?? "127.0.0.1", port: Number(port) });
    const timer = setTimeout(() => {
      socket.destroy();
      fail(new Error(`no ack from the simulator at ${address} to ${JSON.stringify(message)}`));
    }, 5000);
    let buffer = "";
    socket.on("connect", () => socket.write(`${JSON.stringify({ ...message, id })}\n`));
    socket.on("data", (data: Buffer) => {
      buffer += data.toString();
      const lines = buffer.split("\n");
      buffer = lines.pop() ?? "";
      for (const line of lines) {
        const reply = JSON.parse(line) as Record<string, unknown>;
        if (reply["type"] !== "ack" || reply["id"] !== id) continue; // ground truth streams too
        clearTimeout(timer);
        socket.end();
        if (reply["ok"] === true) ok(reply);
        else fail(new Error(`the simulator refused ${JSON.stringify(message)}: ${String(reply["error"])}`));
      }
    });
    socket.on("error", (err) => {
      clearTimeout(timer);
      fail(err);
    });
  });
}
