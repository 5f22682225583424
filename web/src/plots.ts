// Live plots with uPlot: wheel speeds against their targets, v and ω against theirs, the PWMs
// and the distance to the waypoint; everything recorded can be exported as CSV. Frames
// are recorded continuously; the charts redraw a few times a second unless paused.

import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import type { Telemetry } from "./api";
import { cssVar } from "./dom";

const HEIGHT = 230;
const CAPACITY = 50 * 120; // two minutes at the firmware's fastest telemetry rate

type Column = number[];

interface Chart {
  plot: uPlot;
  fields: (keyof Telemetry)[];
}

export class LivePlots {
  private readonly t: Column = [];
  private readonly columns = new Map<keyof Telemetry, Column>();
  private readonly charts: Chart[] = [];
  private readonly t0 = performance.now();
  private windowS = 20;
  paused = false;

  private readonly frames: Telemetry[] = [];

  constructor(wheels: HTMLElement, body: HTMLElement, pwm: HTMLElement, distance: HTMLElement) {
    const css = getComputedStyle(document.documentElement);
    const left = cssVar("--plot-a", "#1d4ed8", css);
    const right = cssVar("--plot-b", "#e76f51", css);
    const axis = axisStyle(css);
    this.charts.push(
      this.chart(wheels, "wheel speed (m/s)", [
        ["v_left", "left", left, false],
        ["v_left_target", "left target", left, true],
        ["v_right", "right", right, false],
        ["v_right_target", "right target", right, true],
      ], axis),
      this.chart(body, "v (m/s), ω (rad/s)", [
        ["v", "v", left, false],
        ["v_target", "v target", left, true],
        ["omega", "ω", right, false],
        ["omega_target", "ω target", right, true],
      ], axis),
      this.chart(pwm, "PWM", [
        ["pwm_left", "left", left, false],
        ["pwm_right", "right", right, false],
      ], axis),
      this.chart(distance, "distance to the waypoint (m)", [
        ["distance_to_waypoint", "distance", left, false],
      ], axis),
    );
    new ResizeObserver(() => this.resize()).observe(wheels);
    setInterval(() => this.redraw(), 200);
  }

  private chart(
    el: HTMLElement,
    title: string,
    series: [keyof Telemetry, string, string, boolean][],
    axis: uPlot.Axis,
  ): Chart {
    for (const [field] of series) this.columns.set(field, []);
    const plot = new uPlot(
      {
        title,
        width: Math.max(280, el.clientWidth),
        height: HEIGHT,
        scales: { x: { time: false }, y: { range: (_u, min, max) => yRange(min, max) } },
        axes: [{ ...axis, label: "s" }, { ...axis }],
        legend: { live: true },
        series: [
          { label: "t (s)" },
          ...series.map(([, label, stroke, dashed]) => ({
            label,
            stroke,
            width: dashed ? 1 : 2,
            dash: dashed ? [6, 4] : [],
            points: { show: false },
          })),
        ],
      },
      [[]],
      el,
    );
    return { plot, fields: series.map(([f]) => f) };
  }

  setWindow(seconds: number): void {
    this.windowS = seconds;
    this.redraw(true);
  }

  add(frame: Telemetry): void {
    this.t.push((performance.now() - this.t0) / 1000);
    this.frames.push(frame);
    for (const [field, column] of this.columns) {
      const v = frame[field];
      column.push(typeof v === "number" ? v : NaN);
    }
    if (this.t.length > CAPACITY) {
      const extra = this.t.length - CAPACITY;
      this.t.splice(0, extra);
      this.frames.splice(0, extra);
      for (const column of this.columns.values()) column.splice(0, extra);
    }
  }

  /** Everything recorded, as CSV: the page's time, then every telemetry field (tick included). */
  csv(): string {
    const first = this.frames[0];
    if (!first) return "";
    const fields = (Object.keys(first) as (keyof Telemetry)[]).filter((k) => k !== "type");
    const cell = (v: unknown): string => {
      const text = Array.isArray(v) ? v.join(" ") : String(v);
      return /[",\n]/.test(text) ? `"${text.replaceAll('"', '""')}"` : text;
    };
    const lines = [["t_s", ...fields].join(",")];
    this.frames.forEach((frame, k) => {
      lines.push([(this.t[k] ?? 0).toFixed(3), ...fields.map((f) => cell(frame[f]))].join(","));
    });
    return lines.join("\n") + "\n";
  }

  private resize(): void {
    for (const { plot } of this.charts) {
      const width = Math.max(240, plot.root.parentElement?.clientWidth ?? 300);
      plot.setSize({ width, height: HEIGHT });
    }
  }

  redraw(force = false): void {
    if (this.paused && !force) return;
    const last = this.t[this.t.length - 1] ?? 0;
    const from = last - this.windowS;
    let start = 0;
    while (start < this.t.length && (this.t[start] ?? 0) < from) start++;
    const t = this.t.slice(start);
    for (const { plot, fields } of this.charts) {
      const data: uPlot.AlignedData = [t, ...fields.map((f) => (this.columns.get(f) ?? []).slice(start))];
      plot.setData(data);
    }
  }
}

/** The axes' and grid's colours of a uPlot chart, from the page's computed `style`. */
export function axisStyle(style: CSSStyleDeclaration): uPlot.Axis {
  return {
    stroke: cssVar("--fg-muted", "#667", style),
    grid: { stroke: cssVar("--grid", "rgba(128,128,128,0.2)", style) },
  };
}

/** A y range that shows a flat line near zero as ±0.1 rather than uPlot's 0..100. */
function yRange(min: number | null, max: number | null): uPlot.Range.MinMax {
  const lo = Math.min(min ?? 0, 0);
  const hi = Math.max(max ?? 0, 0);
  const span = Math.max(hi - lo, 0.2);
  const pad = span * 0.08;
  return [hi - lo < 0.2 ? -0.1 : lo - pad, hi - lo < 0.2 ? Math.max(hi, 0.1) : hi + pad];
}
