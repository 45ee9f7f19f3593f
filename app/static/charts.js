/* gnssatt job page: interactive time series (uPlot, vendored in /static/vendor/uplot) fed by the job's own
 * CSV products through their download URLs.
 *
 *   attitude.csv   Euler angles; errors (<axis>_error_deg columns) or formal 1-sigma; fix status + satellites
 *   errors.csv     any CSV with time_gps and <axis>_error_deg columns: Euler angle errors
 *   baselines.csv  azimuth, elevation, length per baseline; fixed + satellites per baseline
 *   residuals.csv  RMS per epoch of the used phase [mm] and code [m] residuals per baseline and signal
 *   tracking.csv   (inspect) satellites tracked and mean C/N0 per receiver
 *   gps_attitude.csv, bias.csv, faults.csv (gyro-fusion); yaw.csv (satellite-yaw); plan.csv (plan)
 *
 * Interaction: drag to zoom (x), Shift+drag to pan, mouse wheel to zoom around the cursor, double-click to
 * reset all charts to the full span; the legend shows the values under the cursor; all charts share one time
 * axis (zoom and cursor).
 * Times are GPS time, shown as written (no leap-second shift).  window.GnssattCharts.instances lists the
 * charts ({name, title, plot}) for tests. */
(function () {
  "use strict";
  const HEIGHT = 230;
  const MAX_BYTES = 80 * 1024 * 1024; // larger CSVs are linked, not charted (browser memory)
  const MAX_DOTS = 2000; // series marked `points` are drawn as dots up to this many rows, as lines beyond
  const COLOURS = ["#d62728", "#2ca02c", "#1f77b4", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf",
                   "#7f7f7f", "#bcbd22"];
  const EULER = {yaw: "#d62728", pitch: "#2ca02c", roll: "#1f77b4"};
  const registry = {instances: [], mount, parseCSV, chartsFor: (name, text) => chartsFor(name, parseCSV(text))};
  window.GnssattCharts = registry;

  /* --- CSV ------------------------------------------------------------------------------------------ */
  function splitQuoted(line) {
    const out = [];
    let cur = "", quoted = false;
    for (let i = 0; i < line.length; i++) {
      const c = line[i];
      if (quoted) {
        if (c === '"') { if (line[i + 1] === '"') { cur += '"'; i++; } else quoted = false; }
        else cur += c;
      } else if (c === '"') quoted = true;
      else if (c === ",") { out.push(cur); cur = ""; }
      else cur += c;
    }
    out.push(cur);
    return out;
  }

  /** {header: [...], col(name) -> array of strings, n} (quoted fields with commas handled). One pass over the
   * text; each column is built once and cached, so a chart definition costs O(rows). */
  function parseCSV(text) {
    const lines = text.split(/\r?\n/);
    while (lines.length && !lines[lines.length - 1]) lines.pop();
    const header = lines.length ? splitQuoted(lines[0]).map((h) => h.trim()) : [];
    const rows = [];
    for (let i = 1; i < lines.length; i++) {
      const l = lines[i];
      if (!l) continue;
      rows.push(l.indexOf('"') >= 0 ? splitQuoted(l) : l.split(","));
    }
    const index = Object.fromEntries(header.map((h, i) => [h.toLowerCase(), i]));
    const strCache = new Map(), numCache = new Map();
    const col = (name) => {
      const k = index[name.toLowerCase()];
      if (k === undefined) return null;
      if (!strCache.has(k)) {
        const out = new Array(rows.length);
        for (let r = 0; r < rows.length; r++) out[r] = rows[r][k];
        strCache.set(k, out);
      }
      return strCache.get(k);
    };
    return {
      header, n: rows.length,
      has: (name) => Object.prototype.hasOwnProperty.call(index, name.toLowerCase()),
      col,
      num: (name) => {
        const k = index[name.toLowerCase()];
        if (k === undefined) return null;
        if (!numCache.has(k)) {
          const s = col(name), out = new Array(s.length);
          for (let r = 0; r < s.length; r++) { const v = s[r]; out[r] = v === undefined || v === "" ? null : Number(v); }
          numCache.set(k, out);
        }
        return numCache.get(k);
      },
    };
  }

  const gpsSeconds = (iso) => Date.parse(iso.endsWith("Z") ? iso : iso + "Z") / 1000;

  /* Insert a null row where consecutive times are more than 1.5 median steps apart, so lines break at gaps. */
  function withGaps(x, ys) {
    if (x.length < 3) return [x, ys];
    const steps = [];
    for (let i = 1; i < x.length; i++) steps.push(x[i] - x[i - 1]);
    const med = steps.slice().sort((a, b) => a - b)[Math.floor(steps.length / 2)];
    const nx = [], nys = ys.map(() => []);
    for (let i = 0; i < x.length; i++) {
      if (i > 0 && med > 0 && x[i] - x[i - 1] > 1.5 * med) {
        nx.push((x[i] + x[i - 1]) / 2);
        nys.forEach((a) => a.push(null));
      }
      nx.push(x[i]);
      nys.forEach((a, k) => a.push(ys[k][i]));
    }
    return [nx, nys];
  }

  /* Long table (time, key, value) -> aligned x and one series per key. */
  function pivot(times, keys, values) {
    const uniq = Array.from(new Set(times)).sort((a, b) => a - b);
    const at = new Map(uniq.map((t, i) => [t, i]));
    const names = Array.from(new Set(keys));
    const series = names.map(() => new Array(uniq.length).fill(null));
    const idx = new Map(names.map((n, i) => [n, i]));
    for (let r = 0; r < times.length; r++) {
      if (values[r] === null || Number.isNaN(values[r])) continue;
      series[idx.get(keys[r])][at.get(times[r])] = values[r];
    }
    return {x: uniq, names, series};
  }

  /* RMS per (time, key) of values (used rows only). */
  function rmsPerEpoch(times, keys, values, used) {
    const acc = new Map();
    for (let r = 0; r < times.length; r++) {
      const v = values[r];
      if (v === null || Number.isNaN(v) || (used && !used[r])) continue;
      const k = times[r] + "|" + keys[r];
      const a = acc.get(k) || [times[r], keys[r], 0, 0];
      a[2] += v * v; a[3] += 1;
      acc.set(k, a);
    }
    const t = [], k = [], v = [];
    for (const a of acc.values()) { t.push(a[0]); k.push(a[1]); v.push(Math.sqrt(a[2] / a[3])); }
    return pivot(t, k, v);
  }

  const truthy = (s) => ["1", "true", "yes", "y", "t"].includes(String(s).trim().toLowerCase());

  /* --- chart definitions per product ------------------------------------------------------------------ */
  function chartsFor(name, t) {
    const out = [];
    if (!t.has("time_gps") || t.n === 0) return out;
    const times = t.col("time_gps").map(gpsSeconds);
    const lower = name.toLowerCase();
    const errorCols = ["yaw", "pitch", "roll"].filter((a) => t.has(`${a}_error_deg`));
    const fixed = t.has("fixed") ? t.col("fixed").map((v) => (truthy(v) ? 1 : 0)) : null;
    if (lower === "attitude.csv" && t.has("yaw_deg")) {
      out.push({title: "Euler angles (3-2-1) [deg]", y: "deg", x: times, fixed,
                series: ["yaw", "pitch", "roll"].map((a) => ({label: a, values: t.num(`${a}_deg`), stroke: EULER[a]}))});
      if (!errorCols.length && t.has("sigma_yaw_deg")) {
        out.push({title: "Formal 1σ of the Euler angles [deg]", y: "deg", x: times, fixed,
                  series: ["yaw", "pitch", "roll"].map((a) => ({label: `σ ${a}`, values: t.num(`sigma_${a}_deg`), stroke: EULER[a]}))});
      }
      if (t.has("fixed") || t.has("n_sats")) {
        const series = [];
        if (t.has("n_sats")) series.push({label: "satellites used", values: t.num("n_sats"), stroke: "#1f77b4"});
        if (t.has("fixed")) series.push({label: "fixed (1) / float (0)", values: t.col("fixed").map((v) => (truthy(v) ? 1 : 0)),
                                         stroke: "#2ca02c", scale: "fix", step: true});
        out.push({title: "Fix status and satellites used", y: "satellites", y2: "fixed", x: times, series});
      }
    }
    if (errorCols.length) {
      out.push({title: "Euler angle errors (estimate − reference) [deg]", y: "deg", x: times, fixed,
                series: errorCols.map((a) => ({label: `${a} error`, values: t.num(`${a}_error_deg`), stroke: EULER[a], points: true}))});
      if (lower === "errors.csv" && t.has("yaw_ref_deg")) { // the reference itself, when errors.csv carries it
        out.unshift({title: "Reference Euler angles [deg]", y: "deg", x: times, fixed,
          series: ["yaw", "pitch", "roll"].map((a) => ({label: `${a} reference`, values: t.num(`${a}_ref_deg`), stroke: EULER[a], role: "reference"}))});
      }
    }
    if (lower === "baselines.csv" && t.has("baseline")) {
      const keys = t.col("baseline");
      for (const [col, title] of [["azimuth_deg", "Baseline azimuth (heading) [deg]"],
                                  ["elevation_deg", "Baseline elevation [deg]"], ["length_m", "Baseline length [m]"]]) {
        if (!t.has(col)) continue;
        const p = pivot(times, keys, t.num(col));
        out.push({title, y: col.endsWith("_m") ? "m" : "deg", x: p.x,
                  series: p.names.map((n, i) => ({label: n, values: p.series[i]}))});
      }
      if (t.has("fixed")) {
        const p = pivot(times, keys, t.col("fixed").map((v) => (truthy(v) ? 1 : 0)));
        out.push({title: "Baselines fixed (1) / float (0)", y: "fixed", x: p.x,
                  series: p.names.map((n, i) => ({label: n, values: p.series[i], step: true}))});
      }
    }
    if (lower === "residuals.csv") {
      const sigCol = t.col("signal") || [];
      const keys = (t.col("baseline") || times.map(() => "all")).map((b, i) => `${b} ${sigCol[i] || ""}`.trim());
      const used = t.has("used") ? t.col("used").map(truthy) : null;
      let phase = t.num("phase_residual_mm"), code = t.num("code_residual_m");
      if (!phase && t.has("phase_residual_m")) phase = t.num("phase_residual_m").map((v) => (v === null ? null : 1000 * v));
      if (t.has("observable") && t.has("residual_m")) { // long layout: one row per observable (gnssatt/attitude)
        const kind = t.col("observable").map((k) => k.trim().toLowerCase()), r = t.num("residual_m");
        phase = r.map((v, i) => (kind[i] === "phase" && v !== null ? 1000 * v : null));
        code = r.map((v, i) => (kind[i] === "code" ? v : null));
      }
      if (phase) {
        const p = rmsPerEpoch(times, keys, phase, used);
        out.push({title: "Phase residual RMS per epoch [mm]", y: "mm", x: p.x,
                  series: p.names.map((n, i) => ({label: n, values: p.series[i]}))});
      }
      if (code) {
        const p = rmsPerEpoch(times, keys, code, used);
        out.push({title: "Code residual RMS per epoch [m]", y: "m", x: p.x,
                  series: p.names.map((n, i) => ({label: n, values: p.series[i]}))});
      }
    }
    out.push(...laterTypeCharts(lower, t, times));
    if (lower === "tracking.csv" && t.has("receiver")) {
      const keys = t.col("receiver");
      const n = pivot(times, keys, t.num("n_sats"));
      out.push({title: "Satellites tracked per receiver", y: "satellites", x: n.x,
                series: n.names.map((r, i) => ({label: r, values: n.series[i], step: true}))});
      if (t.has("mean_cn0_dbhz")) {
        const c = pivot(times, keys, t.num("mean_cn0_dbhz"));
        out.push({title: "Mean C/N0 per receiver [dB-Hz]", y: "dB-Hz", x: c.x,
                  series: c.names.map((r, i) => ({label: r, values: c.series[i]}))});
      }
    }
    return out;
  }

  /* Main series of the job types added after attitude: gyro-fusion (gps_attitude.csv, bias.csv, faults.csv),
   * satellite-yaw (yaw.csv), plan (plan.csv). Their attitude.csv (gyro-fusion, single-antenna) is charted above. */
  function laterTypeCharts(lower, t, times) {
    const out = [], AX = ["x", "y", "z"];
    if (lower === "gps_attitude.csv" && t.has("yaw_deg")) {
      out.push({title: "GPS snapshot Euler angles (3-2-1) [deg]", y: "deg", x: times,
                series: ["yaw", "pitch", "roll"].map((a) => ({label: `${a} GPS`, values: t.num(`${a}_deg`), stroke: EULER[a], points: true}))});
    }
    if (lower === "bias.csv" && t.has("bias_x_rad_s")) {
      const degH = (v) => (v === null ? null : v * 180 / Math.PI * 3600);
      out.push({title: "Gyro bias estimate [deg/h]", y: "deg/h", x: times,
                series: AX.map((a, i) => ({label: `bias ${a}`, values: t.num(`bias_${a}_rad_s`).map(degH), stroke: COLOURS[i]}))});
    }
    if (lower === "faults.csv" && t.has("J") && t.has("threshold")) {
      out.push({title: "GPS fault test: cost J and its threshold", y: "J", x: times,
                series: [{label: "J", values: t.num("J"), stroke: COLOURS[2], points: true},
                         {label: "threshold", values: t.num("threshold"), stroke: COLOURS[0]}]});
    }
    if (lower === "yaw.csv" && t.has("satellite") && t.has("yaw_deg")) {
      const keys = t.col("satellite"), est = pivot(times, keys, t.num("yaw_deg"));
      const series = est.names.map((n, i) => ({label: `${n} estimate`, values: est.series[i], stroke: COLOURS[(2 * i) % COLOURS.length], points: true}));
      if (t.has("model_yaw_deg")) {
        const mod = pivot(times, keys, t.num("model_yaw_deg"));
        mod.names.forEach((n, i) => series.push({label: `${n} model`, values: mod.series[i], stroke: COLOURS[(2 * i + 1) % COLOURS.length], role: "reference"}));
      }
      out.push({title: "Satellite yaw: estimate and attitude model [deg]", y: "deg", x: est.x, series});
    }
    if (lower === "plan.csv" && t.has("n_sats")) {
      out.push({title: "Satellites in common view", y: "satellites", x: times,
                series: [{label: "satellites", values: t.num("n_sats"), stroke: COLOURS[2], step: true}]});
      const dops = ["hdop", "vdop", "pdop", "adop"].filter((c) => t.has(c));
      if (dops.length) out.push({title: "Dilution of precision", y: "DOP", x: times,
                                 series: dops.map((c, i) => ({label: c.toUpperCase(), values: t.num(c), stroke: COLOURS[i]}))});
      for (const [pre, title] of [["sigma", "Expected 1σ, snapshot (all baselines) [deg]"], ["filter_sigma", "Expected 1σ, filter steady state [deg]"]]) {
        const axes = ["yaw", "pitch", "roll"].filter((a) => t.has(`${pre}_${a}_deg`));
        if (axes.length) out.push({title, y: "deg", x: times,
                                   series: axes.map((a) => ({label: `σ ${a}`, values: t.num(`${pre}_${a}_deg`), stroke: EULER[a]}))});
      }
    }
    return out;
  }

  /* --- uPlot glue ----------------------------------------------------------------------------------------- */
  let syncing = false;
  let fullRange = null; // [min, max] of all charts' times: the shared initial and reset range
  const LEAPS = [["1999-01-01", 13], ["2006-01-01", 14], ["2009-01-01", 15], ["2012-07-01", 16], ["2015-07-01", 17],
                 ["2017-01-01", 18]];
  const clock = {system: "GPS", leap: null}; // shown time system; GPS - UTC [s] of the pass

  function leapAt(sec) {
    let n = 13;
    for (const [d, l] of LEAPS) if (sec >= Date.parse(d + "T00:00:00Z") / 1000) n = l;
    return n;
  }
  const shown = (v) => (clock.system === "UTC" ? v - (clock.leap ?? leapAt(v)) : v);
  const pad2 = (n) => String(n).padStart(2, "0");
  function hms(v) { const d = new Date(shown(v) * 1e3); return `${pad2(d.getUTCHours())}:${pad2(d.getUTCMinutes())}:${pad2(d.getUTCSeconds())}`; }
  function stamp(v) {
    if (v == null) return "–";
    const d = new Date(shown(v) * 1e3);
    return `${d.getUTCFullYear()}-${pad2(d.getUTCMonth() + 1)}-${pad2(d.getUTCDate())} ${hms(v)} ${clock.system}`;
  }

  /* Every chart to one x range (the union of their times unless given), without echoing through syncX. */
  function resetAll(range) {
    const r = range || fullRange;
    if (!r) return;
    syncing = true;
    for (const c of registry.instances) c.plot.setScale("x", {min: r[0], max: r[1]});
    syncing = false;
  }

  function unionRange() {
    let lo = Infinity, hi = -Infinity;
    for (const c of registry.instances) {
      const x = c.plot.data[0];
      if (x.length) { lo = Math.min(lo, x[0]); hi = Math.max(hi, x[x.length - 1]); }
    }
    return lo < hi ? [lo, hi] : null;
  }

  function syncX(u) {
    if (syncing) return;
    syncing = true;
    const {min, max} = u.scales.x;
    for (const c of registry.instances) if (c.plot !== u) c.plot.setScale("x", {min, max});
    syncing = false;
  }

  function setTimeSystem(system) {
    clock.system = system === "UTC" ? "UTC" : "GPS";
    for (const c of registry.instances) {
      c.plot.axes[0].label = `${clock.system} time [hh:mm:ss]`;
      c.plot.redraw(false, true);
      if (c.plot.cursor.idx != null) c.plot.setLegend({idx: c.plot.cursor.idx}); // the legend's time too
    }
  }

  /* Shift+drag pans, the wheel zooms around the cursor (uPlot's own drag zooms, double-click resets). */
  function panZoomPlugin() {
    return {
      hooks: {
        ready: (u) => {
          const over = u.over;
          over.addEventListener("wheel", (e) => {
            e.preventDefault();
            const {min, max} = u.scales.x;
            const at = u.posToVal(e.offsetX, "x");
            const f = e.deltaY < 0 ? 0.8 : 1.25;
            u.setScale("x", {min: at - (at - min) * f, max: at + (max - at) * f});
          }, {passive: false});
          over.addEventListener("mousedown", (e) => {
            if (!e.shiftKey) return;
            e.preventDefault();
            const x0 = e.clientX, {min, max} = u.scales.x;
            const perPx = (max - min) / over.getBoundingClientRect().width;
            const move = (m) => u.setScale("x", {min: min - (m.clientX - x0) * perPx, max: max - (m.clientX - x0) * perPx});
            const up = () => { document.removeEventListener("mousemove", move); document.removeEventListener("mouseup", up); };
            document.addEventListener("mousemove", move);
            document.addEventListener("mouseup", up);
          });
        },
      },
    };
  }

  function fmt(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return "–";
    const a = Math.abs(v);
    return a !== 0 && (a < 1e-3 || a >= 1e6) ? v.toExponential(3) : Number(v.toFixed(a < 1 ? 4 : 3)).toString();
  }

  /* [start, end] x spans of consecutive float (fixed == 0) rows, for shading. */
  function floatSpans(x, fixed) {
    const spans = [];
    if (!fixed) return spans;
    let start = null;
    for (let i = 0; i < x.length; i++) {
      if (x[i] === null || fixed[i] === null || fixed[i] === undefined) continue;
      if (!fixed[i]) { if (start === null) start = i; }
      else if (start !== null) { spans.push([x[start], x[i]]); start = null; }
    }
    if (start !== null) spans.push([x[start], x[x.length - 1]]);
    return spans;
  }

  function lowerBound(x, v) { let lo = 0, hi = x.length; while (lo < hi) { const m = (lo + hi) >> 1; if (x[m] < v) lo = m + 1; else hi = m; } return lo; }

  /* y range of the "y" scale over the FIXED rows within the shown x range (all rows when none is fixed), so
   * the first float epochs (sigma up to tens of degrees) do not flatten the steady state. */
  function fixedRange(fixed, yIdx) {
    return (u, dmin, dmax) => {
      if (!fixed || !fixed.some((f) => f)) return uPlot.rangeNum(dmin, dmax, 0.1, true);
      const x = u.data[0], {min, max} = u.scales.x;
      const i0 = min == null ? 0 : lowerBound(x, min), i1 = max == null ? x.length : lowerBound(x, max + 1e-9);
      let lo = Infinity, hi = -Infinity;
      for (const k of yIdx) {
        const ys = u.data[k];
        for (let i = i0; i < i1; i++) {
          const v = ys[i];
          if (v == null || !fixed[i]) continue;
          if (v < lo) lo = v;
          if (v > hi) hi = v;
        }
      }
      if (!(lo <= hi)) return uPlot.rangeNum(dmin, dmax, 0.1, true);
      return uPlot.rangeNum(lo, hi, 0.1, true);
    };
  }

  function shadePlugin(spans) {
    return {hooks: {drawClear: [(u) => {
      if (!spans.length) return;
      const ctx = u.ctx, {top, height} = u.bbox;
      ctx.save();
      ctx.fillStyle = "rgba(255, 160, 0, 0.13)";
      for (const [a, b] of spans) {
        const x0 = u.valToPos(a, "x", true), x1 = u.valToPos(b, "x", true);
        if (x1 < u.bbox.left || x0 > u.bbox.left + u.bbox.width) continue;
        const l = Math.max(x0, u.bbox.left), r = Math.min(x1, u.bbox.left + u.bbox.width);
        ctx.fillRect(l, top, Math.max(r - l, 1), height);
      }
      ctx.restore();
    }]}};
  }

  const chartWidth = (container) => Math.max(Math.min(container.clientWidth, window.innerWidth - 24) - 4, 260);

  function draw(container, productName, def) {
    const box = document.createElement("div");
    box.className = "chart";
    box.dataset.chartTitle = def.title;
    box.dataset.product = productName;
    if (def.id) box.dataset.chartId = def.id;
    const h = document.createElement("h3");
    h.textContent = def.title;
    const src = document.createElement("span");
    src.className = "muted small";
    src.textContent = `  ·  ${productName}`;
    h.appendChild(src);
    box.appendChild(h);
    container.appendChild(box);
    const extra = def.fixed ? [def.fixed] : [];
    const [x, all] = withGaps(def.x, def.series.map((s) => s.values).concat(extra));
    const ys = def.fixed ? all.slice(0, -1) : all;
    const fixed = def.fixed ? all[all.length - 1] : null;
    const spans = floatSpans(x, fixed);
    const yIdx = def.series.map((s, i) => (s.scale ? -1 : i + 1)).filter((i) => i > 0);
    const scales = {x: {time: true}, y: {auto: true, range: fixedRange(fixed, yIdx)}};
    const axes = [{label: `${clock.system} time [hh:mm:ss]`, labelSize: 18, size: 42, space: 70,
                   values: (u, splits) => splits.map((v) => (v == null ? "" : hms(v)))},
                  {label: def.y, labelSize: 18, size: 56}];
    if (def.series.some((s) => s.scale === "fix")) {
      scales.fix = {range: [-0.1, 1.1]};
      axes.push({scale: "fix", side: 1, label: def.y2 || "", labelSize: 18, size: 40, grid: {show: false},
                 values: (u, vals) => vals.map((v) => (v === 0 || v === 1 ? String(v) : ""))});
    }
    const series = [{label: "time", value: (u, v) => stamp(v)}].concat(def.series.map((s, i) => {
      const colour = s.stroke || (s.axis && EULER[s.axis]) || COLOURS[i % COLOURS.length];
      const ref = s.role === "reference";
      return {
        label: s.label, stroke: colour, width: ref ? 1.75 : 1.25, dash: ref ? [6, 4] : undefined, alpha: ref ? 0.75 : 1,
        scale: s.scale || "y", spanGaps: false, value: (u, v) => fmt(v),
        paths: s.step ? uPlot.paths.stepped({align: 1}) : undefined,
        // dots only where few enough to see apart: a long pass's ~2e4 circles cost more than the rest of a chart
        points: s.points && x.length <= MAX_DOTS ? {show: true, size: 3, stroke: colour, fill: colour} : {show: false},
      };
    }));
    const opts = {
      width: chartWidth(container), height: HEIGHT, series, axes, scales,
      tzDate: (ts) => uPlot.tzDate(new Date(ts * 1e3), "Etc/UTC"),
      cursor: {sync: {key: "gnssatt-job", setSeries: false}, drag: {x: true, y: false, setScale: true},
               bind: {mousedown: (u, targ, handler) => (e) => { if (!e.shiftKey) handler(e); return null; },
                      dblclick: () => () => { resetAll(); return null; }}},
      legend: {live: true},
      hooks: {setScale: [(u, key) => { if (key === "x") syncX(u); }]},
      plugins: [panZoomPlugin(), shadePlugin(spans)],
    };
    syncing = true; // a new chart's own first scale must not move the others
    const plot = new uPlot(opts, [x, ...ys], box);
    syncing = false;
    registry.instances.push({name: productName, title: def.title, id: def.id || null, plot, floatSpans: spans});
    return plot;
  }

  function note(container, text) {
    const p = document.createElement("p");
    p.className = "chart-note";
    p.textContent = text;
    container.appendChild(p);
  }

  async function fetchProduct(p) {
    const resp = await fetch(p.url, {credentials: "same-origin"});
    if (!resp.ok) throw new Error(`HTTP ${resp.status}`);
    return p.name.endsWith(".json") ? resp.json() : resp.text();
  }

  /* charts.json (written by the attitude worker, full per-epoch series) replaces the CSVs it covers. */
  const COVERED = new Set(["attitude.csv", "errors.csv", "baselines.csv", "residuals.csv"]);

  async function mount(container, products) {
    const t0 = performance.now();
    const order = ["charts.json", "attitude.csv", "errors.csv", "baselines.csv", "residuals.csv", "tracking.csv"];
    const hasJson = products.some((p) => p.name === "charts.json");
    const sorted = products.filter((p) => !(hasJson && COVERED.has(p.name))).sort((a, b) => {
      const ia = order.indexOf(a.name), ib = order.indexOf(b.name);
      return (ia < 0 ? 99 : ia) - (ib < 0 ? 99 : ib) || a.name.localeCompare(b.name);
    });
    const status = document.createElement("p");
    status.className = "chart-note";
    status.textContent = "loading time series…";
    container.appendChild(status);
    const fetched = sorted.map((p) => (p.size_bytes && p.size_bytes > MAX_BYTES ? Promise.resolve(null)
                                       : fetchProduct(p).catch((e) => ({error: e}))));
    let drawn = 0;
    for (let i = 0; i < sorted.length; i++) {
      const p = sorted[i], got = await fetched[i];
      if (got === null) { note(container, `${p.name} is too large to chart in the browser; download it below.`); continue; }
      if (got && got.error) { note(container, `${p.name}: could not be charted (${got.error.message || got.error}).`); continue; }
      try {
        let defs;
        if (p.name === "charts.json") {
          if (typeof got.gps_minus_utc_s === "number") clock.leap = got.gps_minus_utc_s;
          defs = got.charts || [];
        } else defs = chartsFor(p.name, parseCSV(got));
        for (const d of defs) { draw(container, p.name, d); drawn++; }
      } catch (e) {
        note(container, `${p.name}: could not be charted (${e.message || e}).`);
      }
    }
    fullRange = unionRange();
    resetAll();
    status.textContent = drawn ? "" : "No time series among this job's products.";
    status.hidden = drawn > 0;
    container.dataset.ready = String(drawn);
    registry.readyMs = performance.now() - t0;
    window.addEventListener("resize", () => {
      for (const c of registry.instances) c.plot.setSize({width: chartWidth(container), height: HEIGHT});
    });
    const sel = document.getElementById("time-system");
    if (sel) sel.addEventListener("change", () => setTimeSystem(sel.value));
    return drawn;
  }
  registry.setTimeSystem = setTimeSystem;
  registry.clock = clock;

  const container = document.getElementById("charts");
  const data = document.getElementById("chart-products");
  if (container && data) mount(container, JSON.parse(data.textContent));
})();
