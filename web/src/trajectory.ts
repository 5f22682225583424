// The x–y trajectory over the plots' time range: the odometry's path against the ground truth's
// (in simulation), on equal axes, so the odometry's drift shows as the gap between two lines.

import { cssVar } from "./dom";
import { DASH, PlotLegend } from "./plot-legend";
import type { TelemetryRecord } from "./record";

type Pt = [number, number];

const HEIGHT = 300;
const MAX_WIDTH = 520; // about square: equal axes leave a wide canvas mostly empty
const MIN_SPAN_M = 0.2;

/** A "nice" grid step (1, 2 or 5 × 10^k) for about `target` lines over `span`. */
function niceStep(span: number, target: number): number {
  const raw = span / target;
  const p = 10 ** Math.floor(Math.log10(raw));
  return ([1, 2, 5, 10].find((m) => m * p >= raw) ?? 10) * p;
}

export class Trajectory {
  private readonly canvas: HTMLCanvasElement;
  private odometry: Pt[] = [];
  private truth: Pt[] = [];

  constructor(
    private readonly host: HTMLElement,
    private readonly note: HTMLElement,
  ) {
    this.canvas = document.createElement("canvas");
    this.canvas.setAttribute("role", "img");
    this.canvas.setAttribute("aria-label", "x–y trajectory: odometry against the true pose");
    const css = getComputedStyle(document.documentElement);
    const legend = new PlotLegend([
      { label: "odometry", stroke: cssVar("--plot-a", "#1d4ed8", css), target: false },
      { label: "true pose (simulation)", stroke: cssVar("--plot-b", "#ea580c", css), target: true },
    ]);
    host.prepend(this.canvas, legend.root);
    this.resize();
  }

  resize(): void {
    const width = Math.min(MAX_WIDTH, Math.max(240, this.host.clientWidth));
    const dpr = window.devicePixelRatio || 1;
    this.canvas.style.width = `${width}px`;
    this.canvas.style.height = `${HEIGHT}px`;
    this.canvas.width = Math.round(width * dpr);
    this.canvas.height = Math.round(HEIGHT * dpr);
    this.paint();
  }

  /** The frames [start, end) of `record`, and the ground truth that arrived meanwhile. */
  draw(record: TelemetryRecord, fromMs: number, toMs: number, start: number, end: number): void {
    this.odometry = record.frames.slice(start, end).map((f) => [f.x, f.y]);
    this.truth = record.truth.filter((p) => p.wallMs >= fromMs && p.wallMs <= toMs).map((p) => [p.x, p.y]);
    const d = this.host.dataset;
    d["odometryPoints"] = String(this.odometry.length);
    d["truthPoints"] = String(this.truth.length);
    const o = this.odometry[this.odometry.length - 1];
    const t = this.truth[this.truth.length - 1];
    this.note.textContent =
      record.truth.length === 0
        ? "The true pose comes from a simulator only: on a real cart this is the odometry's path."
        : o && t
          ? `At the end of this range odometry and true pose are ${(Math.hypot(o[0] - t[0], o[1] - t[1]) * 1000).toFixed(0)} mm apart.`
          : "";
    this.paint();
  }

  private paint(): void {
    const ctx = this.canvas.getContext("2d");
    if (!ctx) return;
    const dpr = window.devicePixelRatio || 1;
    const w = this.canvas.width / dpr;
    const h = this.canvas.height / dpr;
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    ctx.clearRect(0, 0, w, h);
    const all = [...this.odometry, ...this.truth];
    if (all.length === 0) return;
    const xs = all.map((p) => p[0]);
    const ys = all.map((p) => p[1]);
    const cx = (Math.min(...xs) + Math.max(...xs)) / 2;
    const cy = (Math.min(...ys) + Math.max(...ys)) / 2;
    const span = Math.max(MIN_SPAN_M, Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys)) * 1.15;
    const margin = 36;
    const scale = Math.min(w - 2 * margin, h - 2 * margin) / span; // px per m, equal on both axes
    const sx = (x: number): number => w / 2 + (x - cx) * scale;
    const sy = (y: number): number => h / 2 - (y - cy) * scale;
    this.host.dataset["scale"] = scale.toFixed(2);

    const css = getComputedStyle(document.documentElement);
    const muted = cssVar("--fg-muted", "#667", css);
    ctx.strokeStyle = cssVar("--grid", "rgba(128,128,128,0.2)", css);
    ctx.fillStyle = muted;
    ctx.font = "11px system-ui, sans-serif";
    ctx.lineWidth = 1;
    const step = niceStep((w - 2 * margin) / scale, 6);
    const label = (v: number): string => String(Number(v.toFixed(6)));
    for (let x = Math.ceil((cx - w / 2 / scale) / step) * step; sx(x) < w; x += step) {
      ctx.beginPath();
      ctx.moveTo(sx(x), 0);
      ctx.lineTo(sx(x), h - 16);
      ctx.stroke();
      ctx.fillText(label(x), sx(x) + 2, h - 4);
    }
    for (let y = Math.ceil((cy - h / 2 / scale) / step) * step; sy(y) > 0; y += step) {
      ctx.beginPath();
      ctx.moveTo(0, sy(y));
      ctx.lineTo(w, sy(y));
      ctx.stroke();
      ctx.fillText(label(y), 2, sy(y) - 2);
    }
    ctx.fillText("x, y (m)", w - 52, 12);

    const line = (points: Pt[], color: string, dash: number[], width: number): void => {
      if (points.length < 2) return;
      ctx.strokeStyle = color;
      ctx.lineWidth = width;
      ctx.setLineDash(dash);
      ctx.beginPath();
      points.forEach(([x, y], k) => (k === 0 ? ctx.moveTo(sx(x), sy(y)) : ctx.lineTo(sx(x), sy(y))));
      ctx.stroke();
      ctx.setLineDash([]);
    };
    // the odometry below, wider; the truth dashed on top: where they agree both still show
    line(this.odometry, cssVar("--plot-a", "#1d4ed8", css), [], 3);
    line(this.truth, cssVar("--plot-b", "#ea580c", css), DASH, 2);
  }
}
