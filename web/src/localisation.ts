// The pose filter's view on the map (issue 26, docs/localisation.md): the markers of the markers
// file as short bars (on a wall: across its normal; on the floor: a square), and the pose in `map`
// with its uncertainty as the 95 % ellipse of x and y and a wedge of ±2σ heading.
import type { LocalisationMessage } from "./generated/live";

type Point = [number, number];
type ToScreen = (x: number, y: number) => Point;

const CHI2_95_2D = 5.991; // χ²(2) at 95 %: the ellipse holds the cart's true place 95 times in 100

/** The ellipse's semi-axes (m) and its angle (rad) from a 2 x 2 covariance [a b; b c]. */
export function ellipse(a: number, b: number, c: number): { major: number; minor: number; angle: number } {
  const mean = (a + c) / 2;
  const spread = Math.sqrt(((a - c) / 2) ** 2 + b * b);
  const l1 = Math.max(mean + spread, 0);
  const l2 = Math.max(mean - spread, 0);
  return {
    major: Math.sqrt(CHI2_95_2D * l1),
    minor: Math.sqrt(CHI2_95_2D * l2),
    angle: 0.5 * Math.atan2(2 * b, a - c),
  };
}

export function drawLocalisation(
  ctx: CanvasRenderingContext2D,
  loc: LocalisationMessage,
  toScreen: ToScreen,
  scale: number,
  color: string,
): void {
  ctx.save();
  ctx.strokeStyle = color;
  ctx.fillStyle = color;
  ctx.lineWidth = 3;
  for (const m of loc.markers) {
    const yaw = (m.yaw_deg * Math.PI) / 180;
    const [px, py] = toScreen(m.x, m.y);
    const half = (m.size_m / 2) * scale;
    ctx.beginPath();
    if (m.on === "floor") {
      ctx.rect(px - half, py - half, 2 * half, 2 * half);
      ctx.globalAlpha = 0.5;
      ctx.fill();
      ctx.globalAlpha = 1;
    } else {
      // the bar along the wall (across the normal), screen y down
      const dx = -Math.sin(yaw) * half;
      const dy = -Math.cos(yaw) * half;
      ctx.moveTo(px - dx, py - dy);
      ctx.lineTo(px + dx, py + dy);
      ctx.stroke();
    }
  }
  const p = loc.pose;
  const cov = loc.covariance;
  if (p && cov.length === 9) {
    const e = ellipse(cov[0] ?? 0, cov[1] ?? 0, cov[4] ?? 0);
    const [px, py] = toScreen(p.x, p.y);
    ctx.lineWidth = 1.5;
    ctx.setLineDash(loc.trusted ? [] : [4, 3]);
    ctx.beginPath();
    // screen y points down: the angle flips
    ctx.ellipse(px, py, Math.max(e.major * scale, 2), Math.max(e.minor * scale, 2), -e.angle, 0, 2 * Math.PI);
    ctx.stroke();
    const sigma = Math.sqrt(Math.max(cov[8] ?? 0, 0));
    const spread = Math.min(2 * sigma, Math.PI);
    const r = 0.25 * scale;
    ctx.globalAlpha = 0.25;
    ctx.beginPath();
    ctx.moveTo(px, py);
    ctx.arc(px, py, r, -p.theta - spread, -p.theta + spread);
    ctx.closePath();
    ctx.fill();
    ctx.restore();
    return;
  }
  ctx.restore();
}

/** The odometry's pose in `map` through map -> odom (the identity without markers). */
export function inMap<P extends { x: number; y: number; theta: number }>(
  pose: P,
  mapToOdom: { x: number; y: number; theta: number } | undefined,
): P {
  if (!mapToOdom) return pose;
  const c = Math.cos(mapToOdom.theta);
  const s = Math.sin(mapToOdom.theta);
  return {
    ...pose,
    x: mapToOdom.x + c * pose.x - s * pose.y,
    y: mapToOdom.y + s * pose.x + c * pose.y,
    theta: pose.theta + mapToOdom.theta,
  };
}
