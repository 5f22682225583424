// One legend per plot, drawn by the panel instead of uPlot's: each series with a sample of its
// line (measured solid, target dashed, in the colour of its wheel or quantity) and, while the
// pointer is over the plot, its value there.

import type uPlot from "uplot";
import { num } from "./format";

export interface SeriesStyle {
  label: string;
  stroke: string;
  target: boolean; // a target (dashed, thinner) rather than a measured value (solid)
}

export const DASH = [6, 4];
const SVG = "http://www.w3.org/2000/svg";

/** uPlot's options for a series drawn in `style`. */
export function seriesOptions(style: SeriesStyle): uPlot.Series {
  return {
    label: style.label,
    stroke: style.stroke,
    width: style.target ? 1.5 : 2,
    dash: style.target ? DASH : [],
    points: { show: false },
  };
}

function sample(style: SeriesStyle): SVGSVGElement {
  const svg = document.createElementNS(SVG, "svg");
  svg.setAttribute("width", "26");
  svg.setAttribute("height", "10");
  svg.setAttribute("aria-hidden", "true");
  const line = document.createElementNS(SVG, "line");
  line.setAttribute("x1", "0");
  line.setAttribute("y1", "5");
  line.setAttribute("x2", "26");
  line.setAttribute("y2", "5");
  line.setAttribute("stroke", style.stroke);
  line.setAttribute("stroke-width", style.target ? "1.5" : "2.5");
  if (style.target) line.setAttribute("stroke-dasharray", DASH.join(" "));
  svg.append(line);
  return svg;
}

export class PlotLegend {
  readonly root: HTMLElement;
  private readonly values: HTMLElement[] = [];

  constructor(styles: SeriesStyle[]) {
    this.root = document.createElement("div");
    this.root.className = "plot-legend";
    for (const style of styles) {
      const item = document.createElement("span");
      item.className = `key ${style.target ? "key-target" : "key-measured"}`;
      item.dataset["series"] = style.label;
      const label = document.createElement("span");
      label.textContent = style.label;
      const value = document.createElement("span");
      value.className = "key-value";
      this.values.push(value);
      item.append(sample(style), label, value);
      this.root.append(item);
    }
  }

  /** The values under the pointer (uPlot's setCursor hook); blank when it left the plot. */
  cursor(u: uPlot): void {
    const idx = u.cursor.idx;
    this.values.forEach((el, k) => {
      const v = idx === null || idx === undefined ? undefined : u.data[k + 1]?.[idx];
      el.textContent = typeof v === "number" ? num(v, 3) : "";
    });
  }
}
