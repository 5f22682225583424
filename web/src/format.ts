// Numbers and counts as a person reads them: no float32 rounding noise, units, plurals.

/** A value the firmware holds as float32, shown without its rounding noise: 0.004999999888241291
 * is 0.005 (float32 carries about 7 significant digits; 6 keep the noise out). */
export function num(v: number, significant = 6): string {
  if (!Number.isFinite(v)) return String(v);
  const text = String(Number(v.toPrecision(significant)));
  return text === "-0" ? "0" : text;
}

/** "1 waypoint", "11 waypoints". */
export function count(n: number, one: string, many = `${one}s`): string {
  return `${n} ${n === 1 ? one : many}`;
}

/** A duration since something, for a person: "0.4 s", "12 s", "3 min 5 s". */
export function age(seconds: number): string {
  if (seconds < 10) return `${seconds.toFixed(1)} s`;
  if (seconds < 60) return `${Math.round(seconds)} s`;
  const m = Math.floor(seconds / 60);
  return `${m} min ${Math.round(seconds - m * 60)} s`;
}
