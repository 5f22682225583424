// The map's view: which world rectangle the canvas shows (zoom and pan), and the axes in metres.
// World: metres, y up (REP-103); screen: CSS pixels of the canvas, y down.

import type { Arena, Point } from "./api";

export const AXIS_LEFT_PX = 44; // room for the y labels
export const AXIS_BOTTOM_PX = 22; // and the x labels
const EDGE_PX = 6;
export const MIN_SCALE = 2; // px per metre: a 400 m building across 800 px
export const MAX_SCALE = 4000; // a millimetre in 4 px

export class Viewport {
  scale = 1; // CSS px per metre
  ox = 0; // CSS px of the world's x = 0
  oy = 0; // CSS px of the world's y = 0
  fitted = true; // the view is the fit of the map (kept through resizes until the user zooms or pans)

  toScreen(x: number, y: number): Point {
    return [this.ox + x * this.scale, this.oy - y * this.scale];
  }

  toWorld(px: number, py: number): Point {
    return [(px - this.ox) / this.scale, (this.oy - py) / this.scale];
  }

  /** The whole extent in the canvas, centred, beside the axes. */
  fit(e: Arena, cssW: number, cssH: number): void {
    const w = Math.max(e.x_max - e.x_min, 1e-6);
    const h = Math.max(e.y_max - e.y_min, 1e-6);
    const innerW = Math.max(cssW - AXIS_LEFT_PX - EDGE_PX, 10);
    const innerH = Math.max(cssH - AXIS_BOTTOM_PX - EDGE_PX, 10);
    this.scale = clamp(Math.min(innerW / w, innerH / h), MIN_SCALE, MAX_SCALE);
    this.ox = AXIS_LEFT_PX + (innerW - w * this.scale) / 2 - e.x_min * this.scale;
    this.oy = EDGE_PX + innerH - (innerH - h * this.scale) / 2 + e.y_min * this.scale;
    this.fitted = true;
  }

  /** Zooms by `factor` keeping the world point under (px, py) where it is. */
  zoomAt(px: number, py: number, factor: number): void {
    const [wx, wy] = this.toWorld(px, py);
    this.scale = clamp(this.scale * factor, MIN_SCALE, MAX_SCALE);
    this.ox = px - wx * this.scale;
    this.oy = py + wy * this.scale;
    this.fitted = false;
  }

  pan(dx: number, dy: number): void {
    this.ox += dx;
    this.oy += dy;
    this.fitted = false;
  }

  /** The world rectangle the canvas shows. */
  visible(cssW: number, cssH: number): Arena {
    const [x0, y1] = this.toWorld(0, 0);
    const [x1, y0] = this.toWorld(cssW, cssH);
    return { x_min: x0, y_min: y0, x_max: x1, y_max: y1 };
  }
}

function clamp(v: number, lo: number, hi: number): number {
  return Math.min(Math.max(v, lo), hi);
}

/** A tick spacing of 1, 2 or 5 × 10^k metres, at least `minPx` apart on screen. */
/** Sizes `canvas` to its parent's width and the arena's aspect (plus the x axis), at most
 * `heightShare` of the window, at the device's pixel ratio; its CSS size. */
export function sizeCanvas(canvas: HTMLCanvasElement, e: Arena, heightShare: number): { cssW: number; cssH: number } {
  const parent = canvas.parentElement;
  const cssW = Math.max(200, parent ? parent.clientWidth : 0);
  const aspect = (e.y_max - e.y_min) / (e.x_max - e.x_min);
  const cssH = Math.min(cssW * aspect + AXIS_BOTTOM_PX, Math.max(260, window.innerHeight * heightShare));
  const dpr = window.devicePixelRatio || 1;
  canvas.style.width = `${cssW}px`;
  canvas.style.height = `${cssH}px`;
  canvas.width = Math.round(cssW * dpr);
  canvas.height = Math.round(cssH * dpr);
  return { cssW, cssH };
}

export function tickStep(scale: number, minPx = 60): number {
  const raw = minPx / scale;
  const base = 10 ** Math.floor(Math.log10(raw));
  for (const m of [1, 2, 5, 10]) if (m * base >= raw) return m * base;
  return 10 * base;
}

function label(v: number, step: number): string {
  const digits = Math.max(0, -Math.floor(Math.log10(step) + 1e-9));
  return v.toFixed(digits);
}

/** Metre ticks and labels along the bottom and the left, over a light band. */
export function drawAxes(
  ctx: CanvasRenderingContext2D,
  view: Viewport,
  cssW: number,
  cssH: number,
  colors: { text: string; grid: string; band: string },
): void {
  const step = tickStep(view.scale);
  const v = view.visible(cssW, cssH);
  ctx.save();
  ctx.fillStyle = colors.band;
  ctx.fillRect(0, cssH - AXIS_BOTTOM_PX, cssW, AXIS_BOTTOM_PX);
  ctx.fillRect(0, 0, AXIS_LEFT_PX, cssH);
  ctx.font = "11px system-ui, sans-serif";
  ctx.fillStyle = colors.text;
  ctx.strokeStyle = colors.grid;
  ctx.lineWidth = 1;
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  for (let x = Math.ceil(v.x_min / step) * step; x <= v.x_max; x += step) {
    const [px] = view.toScreen(x, 0);
    if (px < AXIS_LEFT_PX) continue;
    ctx.beginPath();
    ctx.moveTo(Math.round(px) + 0.5, cssH - AXIS_BOTTOM_PX);
    ctx.lineTo(Math.round(px) + 0.5, cssH - AXIS_BOTTOM_PX + 4);
    ctx.stroke();
    ctx.fillText(label(x, step), px, cssH - AXIS_BOTTOM_PX + 5);
  }
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  for (let y = Math.ceil(v.y_min / step) * step; y <= v.y_max; y += step) {
    const [, py] = view.toScreen(0, y);
    if (py > cssH - AXIS_BOTTOM_PX) continue;
    ctx.beginPath();
    ctx.moveTo(AXIS_LEFT_PX - 4, Math.round(py) + 0.5);
    ctx.lineTo(AXIS_LEFT_PX, Math.round(py) + 0.5);
    ctx.stroke();
    ctx.fillText(label(y, step), AXIS_LEFT_PX - 6, py);
  }
  ctx.textAlign = "left";
  ctx.textBaseline = "bottom";
  ctx.fillText("m", 4, cssH - 4);
  ctx.restore();
}
