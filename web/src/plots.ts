// Live plots with uPlot on the firmware's time axis (TICK × 8 ms): wheel speeds against their
// targets, v and ω against theirs, the PWMs, the distance to the waypoint, and the x–y
// trajectory (odometry against the simulator's ground truth). Frames are recorded continuously
// (record.ts); the charts redraw a few times a second following the last `window` seconds, unless
// held: paused, or zoomed (the − / + buttons, Ctrl + wheel over a plot), which holds the view
// until "Live". The CSV export holds what the plots show while they are held, else everything.

import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import type { Telemetry } from "./api";
import { cssVar } from "./dom";
import { PlotLegend, seriesOptions, type SeriesStyle } from "./plot-legend";
import type { Range, TelemetryRecord } from "./record";
import type { Trajectory } from "./trajectory";

const HEIGHT = 220;
const MIN_SPAN_S = 0.25;

interface Chart {
  plot: uPlot;
  fields: (keyof Telemetry)[];
}

export interface PlotHosts {
  wheels: HTMLElement;
  body: HTMLElement;
  pwm: HTMLElement;
  distance: HTMLElement;
}

export class LivePlots {
  private readonly charts: Chart[] = [];
  private windowS = 20;
  private held: Range | null = null; // paused or zoomed: this range; null: live
  /** Called when the plots start or stop holding (the Pause button shows it). */
  onHold: (held: boolean) => void = () => {};

  constructor(
    private readonly record: TelemetryRecord,
    hosts: PlotHosts,
    private readonly trajectory: Trajectory,
    private readonly card: HTMLElement,
  ) {
    const css = getComputedStyle(document.documentElement);
    const a = cssVar("--plot-a", "#1d4ed8", css);
    const b = cssVar("--plot-b", "#e76f51", css);
    const axis = axisStyle(css);
    const s = (label: string, stroke: string, target = false): SeriesStyle => ({ label, stroke, target });
    this.charts.push(
      this.chart(hosts.wheels, "wheel speed (m/s)", axis, [
        ["v_left", s("left", a)],
        ["v_left_target", s("left target", a, true)],
        ["v_right", s("right", b)],
        ["v_right_target", s("right target", b, true)],
      ]),
      this.chart(hosts.body, "v (m/s), ω (rad/s)", axis, [
        ["v", s("v", a)],
        ["v_target", s("v target", a, true)],
        ["omega", s("ω", b)],
        ["omega_target", s("ω target", b, true)],
      ]),
      this.chart(hosts.pwm, "PWM", axis, [
        ["pwm_left", s("left", a)],
        ["pwm_right", s("right", b)],
      ]),
      this.chart(hosts.distance, "distance to the waypoint (m)", axis, [["distance_to_waypoint", s("distance", a)]]),
    );
    new ResizeObserver(() => this.resize()).observe(hosts.wheels);
    window.setInterval(() => this.redraw(), 200);
  }

  private chart(el: HTMLElement, title: string, axis: uPlot.Axis, series: [keyof Telemetry, SeriesStyle][]): Chart {
    const legend = new PlotLegend(series.map(([, style]) => style));
    const plot = new uPlot(
      {
        title,
        width: Math.max(280, el.clientWidth),
        height: HEIGHT,
        scales: { x: { time: false }, y: { range: (_u, min, max) => yRange(min, max) } },
        axes: [{ ...axis, label: "s (firmware time)" }, { ...axis }],
        legend: { show: false },
        cursor: { drag: { x: false, y: false } },
        hooks: { setCursor: [(u) => legend.cursor(u)] },
        series: [{ label: "t (s)" }, ...series.map(([, style]) => seriesOptions(style))],
      },
      [[]],
      el,
    );
    el.append(legend.root);
    el.addEventListener(
      "wheel",
      (e) => {
        if (!(e.ctrlKey || e.metaKey)) return; // a plain wheel scrolls the page
        e.preventDefault();
        const box = plot.over.getBoundingClientRect();
        const at = e.clientX >= box.left && e.clientX <= box.right ? plot.posToVal(e.clientX - box.left, "x") : undefined;
        this.zoom(e.deltaY < 0 ? 0.8 : 1.25, at);
      },
      { passive: false },
    );
    return { plot, fields: series.map(([f]) => f) };
  }

  get holding(): boolean {
    return this.held !== null;
  }

  setWindow(seconds: number): void {
    this.windowS = seconds;
    if (this.held) this.held = this.clamp(this.held.to - seconds, this.held.to);
    this.redraw(true);
  }

  /** The range on screen: the held one, or the last `window` seconds. */
  shown(): Range {
    if (this.held) return this.held;
    const last = this.record.lastT;
    return { from: Math.max(this.record.firstT, last - this.windowS), to: last };
  }

  /** Holds what is on screen (paused), or follows the telemetry again. */
  hold(on: boolean): void {
    this.held = on ? this.shown() : null;
    this.onHold(on);
    this.redraw(true);
  }

  /** Zooms the time axis by `factor` (< 1: in) around `at` (s; the middle without), and holds. */
  zoom(factor: number, at?: number): void {
    const r = this.shown();
    const span = Math.max(MIN_SPAN_S, (r.to - r.from) * factor);
    const centre = at ?? (r.from + r.to) / 2;
    const left = (centre - r.from) / (r.to - r.from || 1); // where `at` is, kept under the pointer
    const wasHeld = this.held !== null;
    this.held = this.clamp(centre - left * span, centre + (1 - left) * span);
    if (!wasHeld) this.onHold(true);
    this.redraw(true);
  }

  /** A range of the given ends, moved and cut to lie within what was recorded. */
  private clamp(from: number, to: number): Range {
    const first = this.record.firstT;
    const last = this.record.lastT;
    const span = Math.min(to - from, last - first);
    if (from < first) return { from: first, to: first + span };
    if (to > last) return { from: last - span, to: last };
    return { from, to };
  }

  /** The CSV export: what is on screen while held, else everything recorded. */
  csv(): string {
    return this.record.csv(this.held ?? undefined);
  }

  private resize(): void {
    for (const { plot } of this.charts) {
      const width = Math.max(240, plot.root.parentElement?.clientWidth ?? 300);
      plot.setSize({ width, height: HEIGHT });
    }
    this.trajectory.resize();
  }

  redraw(force = false): void {
    if (this.held && !force) return;
    const r = this.shown();
    const [start, end] = this.record.indices(r);
    const t = this.record.t.slice(start, end);
    for (const { plot, fields } of this.charts) {
      const columns = fields.map((f) => this.record.frames.slice(start, end).map((frame) => Number(frame[f])));
      plot.setData([t, ...columns] as uPlot.AlignedData);
      if (t.length > 1) plot.setScale("x", { min: r.from, max: r.to });
    }
    const d = this.card.dataset;
    d["viewFrom"] = r.from.toFixed(3);
    d["viewTo"] = r.to.toFixed(3);
    d["points"] = String(end - start);
    d["lastTick"] = String(this.record.frames[end - 1]?.tick ?? "");
    d["held"] = String(this.held !== null);
    const wall = this.record.wallMs;
    this.trajectory.draw(this.record, wall[start] ?? 0, wall[end - 1] ?? Number.MAX_SAFE_INTEGER, start, end);
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
