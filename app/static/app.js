/* gnssatt pages: live job progress (SSE), upload and job forms, cancel. Vanilla JS, no framework.
 * Every state-changing call sends the page's CSRF token (X-CSRF-Token), as the server requires for
 * requests authenticated by the sign-in cookie. */
(function () {
  "use strict";
  const TERMINAL = ["succeeded", "failed", "cancelled"];
  const MAX_STREAMS = 4; // browsers allow ~6 connections per host; keep some for fetches and images
  const meta = document.querySelector('meta[name="csrf-token"]');
  const csrf = meta ? meta.content : "";

  function el(tag, attrs, text) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
    if (text !== undefined) e.textContent = text;
    return e;
  }

  async function api(method, url, body) {
    const headers = {"Accept": "application/json, application/problem+json", "X-CSRF-Token": csrf};
    const init = {method, headers, credentials: "same-origin"};
    if (body instanceof FormData) init.body = body;
    else if (body !== undefined) { headers["Content-Type"] = "application/json"; init.body = JSON.stringify(body); }
    const resp = await fetch(url, init);
    let doc = null;
    try { doc = await resp.json(); } catch (e) { doc = null; }
    if (!resp.ok) {
      const problem = doc && doc.title ? doc : {title: `HTTP ${resp.status}`, status: resp.status,
                                                 detail: "The server answered without a problem document."};
      const err = new Error(problem.title);
      err.problem = problem;
      throw err;
    }
    return {status: resp.status, headers: resp.headers, body: doc};
  }

  /* POST a FormData with upload progress (fetch cannot report it): resolves like api(), calls
   * onProgress(sentBytes, totalBytes) while the body goes out, then onProgress(null) while the server checks. */
  function postWithProgress(url, data, onProgress) {
    return new Promise((resolve, reject) => {
      const xhr = new XMLHttpRequest();
      xhr.open("POST", url);
      xhr.withCredentials = true;
      xhr.setRequestHeader("Accept", "application/json, application/problem+json");
      xhr.setRequestHeader("X-CSRF-Token", csrf);
      xhr.upload.addEventListener("progress", (ev) => { if (ev.lengthComputable) onProgress(ev.loaded, ev.total); });
      xhr.upload.addEventListener("load", () => onProgress(null, null));
      xhr.addEventListener("load", () => {
        let doc = null;
        try { doc = JSON.parse(xhr.responseText); } catch (e) { doc = null; }
        if (xhr.status >= 200 && xhr.status < 300) { resolve({status: xhr.status, body: doc}); return; }
        const problem = doc && doc.title ? doc : {title: `HTTP ${xhr.status}`, status: xhr.status,
                                                   detail: "The server answered without a problem document."};
        const err = new Error(problem.title);
        err.problem = problem;
        reject(err);
      });
      xhr.addEventListener("error", () => {
        const err = new Error("The upload did not reach the server");
        err.problem = {title: "The upload did not reach the server",
                       detail: "The connection failed or was interrupted. Nothing was stored; try again."};
        reject(err);
      });
      xhr.send(data);
    });
  }

  function fmtBytes(n) {
    if (n < 1024) return `${n} B`;
    if (n < 1024 ** 2) return `${(n / 1024).toFixed(1)} KiB`;
    if (n < 1024 ** 3) return `${(n / 1024 ** 2).toFixed(1)} MiB`;
    return `${(n / 1024 ** 3).toFixed(2)} GiB`;
  }

  /* Show an RFC 9457 problem document: title, detail, file, line, field and per-field errors. */
  function showProblem(box, problem) {
    if (!box) return;
    box.replaceChildren();
    box.appendChild(el("b", {}, problem.title || "Error"));
    if (problem.detail) box.appendChild(el("div", {class: "detail"}, problem.detail));
    if (problem.file) {
      const d = el("div", {class: "where"}, "file ");
      d.appendChild(el("code", {}, problem.file));
      if (problem.line) d.appendChild(document.createTextNode(`, line ${problem.line}`));
      box.appendChild(d);
    }
    if (problem.field) {
      const d = el("div", {class: "field"}, "field ");
      d.appendChild(el("code", {}, problem.field));
      box.appendChild(d);
    }
    if (Array.isArray(problem.errors) && problem.errors.length > 1) {
      const ul = el("ul");
      for (const e of problem.errors.slice(0, 20)) ul.appendChild(el("li", {}, `${e.field || ""}: ${e.message || ""}`));
      box.appendChild(ul);
    }
    box.hidden = false;
  }

  /* --- live progress ------------------------------------------------------------------------------- */
  function paint(node, job) {
    node.dataset.state = job.state;
    const bar = node.querySelector(".js-progress");
    if (bar) bar.value = job.progress;
    const pct = node.querySelector(".js-percent");
    if (pct) pct.textContent = `${Math.round(job.progress * 100)}%`;
    const stage = node.querySelector(".js-stage");
    if (stage) stage.textContent = job.stage || "";
    const state = node.querySelector(".js-state");
    if (state) {
      const badge = el("span", {class: `state state-${job.state}`}, job.state);
      state.replaceChildren(badge);
    }
    const prob = node.querySelector(".js-problem");
    if (prob && job.error) showProblem(prob, job.error);
  }

  function follow(node, onEnd) {
    const id = node.dataset.jobId;
    const source = new EventSource(`/v1/jobs/${encodeURIComponent(id)}/events`);
    source.addEventListener("progress", (ev) => paint(node, JSON.parse(ev.data)));
    source.addEventListener("end", (ev) => {
      const job = JSON.parse(ev.data);
      paint(node, job);
      source.close();
      if (onEnd) onEnd(job);
    });
    source.onerror = () => { if (TERMINAL.includes(node.dataset.state)) source.close(); };
    return source;
  }

  function startLiveProgress() {
    const status = document.getElementById("job-status");
    if (status) {
      if (!TERMINAL.includes(status.dataset.state)) {
        follow(status, () => setTimeout(() => window.location.reload(), 400));
      }
      return;
    }
    const rows = Array.from(document.querySelectorAll("tr.job[data-job-id]"))
      .filter((r) => !TERMINAL.includes(r.dataset.state)).slice(0, MAX_STREAMS);
    rows.forEach((r) => follow(r));
  }

  /* --- cancel ------------------------------------------------------------------------------------- */
  function wireCancel() {
    const button = document.getElementById("cancel-job");
    if (!button) return;
    button.addEventListener("click", async () => {
      if (!window.confirm("Cancel this job?")) return;
      button.disabled = true;
      try {
        await api("POST", `/v1/jobs/${encodeURIComponent(button.dataset.jobId)}/cancel`);
      } catch (e) {
        showProblem(document.querySelector("#job-status .js-problem"), e.problem || {title: String(e)});
        button.disabled = false;
      }
    });
  }

  /* --- delete (job page, set page): confirm, DELETE, then the page in data-next ---------------------------- */
  function wireDelete() {
    for (const button of document.querySelectorAll("button.js-delete[data-url]")) {
      button.addEventListener("click", async () => {
        if (!window.confirm(`Delete this ${button.dataset.what}? This cannot be undone.`)) return;
        button.disabled = true;
        const box = document.getElementById("delete-problem");
        try {
          await api("DELETE", button.dataset.url);
          window.location.assign(button.dataset.next || "/ui");
        } catch (e) {
          showProblem(box, e.problem || {title: String(e)});
          button.disabled = false;
        }
      });
    }
  }

  /* --- upload and job forms ------------------------------------------------------------------------ */
  function defaultsOf(schema) {
    const out = {};
    for (const [name, prop] of Object.entries((schema && schema.properties) || {})) {
      if (Object.prototype.hasOwnProperty.call(prop, "default")) out[name] = prop.default;
    }
    return out;
  }

  /* One help line per config field, nested objects as nested lists: type, allowed values or range, default, and
     the field's description (the schema's own words; $ref and Optional's anyOf resolved). */
  function resolveRef(root, prop) {
    let p = prop || {};
    for (let i = 0; i < 8 && p.$ref; i++) p = {...((root.$defs || {})[p.$ref.split("/").pop()] || {}), ...p, $ref: undefined};
    const alt = (p.anyOf || p.oneOf || []).filter((a) => a.type !== "null");
    if (alt.length === 1) p = {...resolveRef(root, alt[0]), ...p, anyOf: undefined, oneOf: undefined};
    if (p.allOf && p.allOf.length === 1) p = {...resolveRef(root, p.allOf[0]), ...p, allOf: undefined};
    return p;
  }

  function fieldFacts(p) {
    const facts = [];
    if (p.enum) facts.push(`one of ${p.enum.map((v) => JSON.stringify(v)).join(", ")}`);
    else if (p.type) facts.push(p.type === "array" && p.items && p.items.type ? `array of ${p.items.type}` : p.type);
    const lo = p.minimum !== undefined ? `[${p.minimum}` : (p.exclusiveMinimum !== undefined ? `(${p.exclusiveMinimum}` : null);
    const hi = p.maximum !== undefined ? `${p.maximum}]` : (p.exclusiveMaximum !== undefined ? `${p.exclusiveMaximum})` : null);
    if (lo || hi) facts.push(`range ${lo || "(-inf"}, ${hi || "inf)"}`);
    if (p.minItems !== undefined || p.maxItems !== undefined) facts.push(`${p.minItems ?? 0} to ${p.maxItems ?? "any"} items`);
    if (Object.prototype.hasOwnProperty.call(p, "default") && (p.default === null || typeof p.default !== "object"))
      facts.push(`default ${JSON.stringify(p.default)}`);
    return facts.join("; ");
  }

  function fieldItems(root, schema, prefix) {
    const items = [];
    for (const [name, raw] of Object.entries(resolveRef(root, schema).properties || {})) {
      const p = resolveRef(root, raw);
      const path = prefix ? `${prefix}.${name}` : name;
      const li = el("li", {"data-field": path});
      li.appendChild(el("code", {}, path));
      const facts = fieldFacts(p);
      if (facts) li.appendChild(el("span", {class: "muted js-field-facts"}, ` (${facts})`));
      li.appendChild(document.createTextNode(` ${p.description || p.title || ""}`));
      if (p.properties) {
        const sub = el("ul");
        sub.replaceChildren(...fieldItems(root, p, path));
        li.appendChild(sub);
      }
      items.push(li);
    }
    return items;
  }

  function wireNewPage() {
    const uploadForm = document.getElementById("upload-form");
    const jobForm = document.getElementById("job-form");
    if (!uploadForm || !jobForm) return;
    const typeSelect = document.getElementById("job-type");
    const setsSelect = document.getElementById("job-sets");
    const config = document.getElementById("job-config");
    const help = jobForm.querySelector(".js-type-help");
    const fieldHelp = jobForm.querySelector(".js-config-help");
    const jobProblem = jobForm.parentElement.querySelector(".js-problem");
    let types = {};

    function describe() {
      const t = types[typeSelect.value];
      fieldHelp.replaceChildren();
      if (!t) { help.textContent = ""; return; }
      const sets = t.max_sets === 0 ? "no observation set" :
        (t.min_sets === t.max_sets ? `${t.min_sets} observation set(s)` :
          `${t.min_sets} to ${t.max_sets === null ? "any number of" : t.max_sets} observation sets`);
      help.textContent = `${t.description} Takes ${sets}.`;
      config.value = JSON.stringify(defaultsOf(t.config_schema), null, 2);
      fieldHelp.replaceChildren(...fieldItems(t.config_schema || {}, t.config_schema || {}, ""));
    }

    api("GET", "/v1/job-types").then(({body}) => {
      typeSelect.replaceChildren(el("option", {value: ""}, "choose a job type…"));
      for (const t of body) {
        types[t.name] = t;
        typeSelect.appendChild(el("option", {value: t.name}, `${t.name} · ${t.title}`));
      }
      typeSelect.dataset.loaded = "1";
    }).catch((e) => showProblem(jobProblem, e.problem || {title: String(e)}));
    typeSelect.addEventListener("change", describe);

    uploadForm.addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const box = uploadForm.parentElement.querySelector(".js-problem");
      const ok = uploadForm.parentElement.querySelector(".js-ok");
      const busy = uploadForm.querySelector(".js-busy");
      const button = document.getElementById("upload-button");
      const bar = document.getElementById("upload-progress");
      const label = uploadForm.querySelector(".js-upload-label");
      box.hidden = true; ok.hidden = true; busy.hidden = false; button.disabled = true;
      bar.hidden = false; bar.value = 0; bar.removeAttribute("data-done"); label.textContent = "uploading…";
      const data = new FormData();
      const name = document.getElementById("set-name").value.trim();
      if (name) data.append("name", name);
      for (const f of document.getElementById("set-files").files) data.append("files", f, f.name);
      try {
        const {body} = await postWithProgress("/v1/observation-sets", data, (sent, total) => {
          if (sent === null) {  // every byte sent: the server now checks the files
            bar.value = bar.max; bar.dataset.done = "1"; label.textContent = "uploaded; checking the files…";
            return;
          }
          bar.max = total; bar.value = sent;
          label.textContent = `uploading ${fmtBytes(sent)} of ${fmtBytes(total)} (${Math.floor(100 * sent / total)} %)`;
        });
        ok.replaceChildren(document.createTextNode("Uploaded and checked: "));
        const a = el("a", {href: `/ui/sets/${body.id}`, id: "uploaded-set"}, body.name || body.id);
        a.dataset.setId = body.id;
        ok.appendChild(a);
        ok.appendChild(document.createTextNode(` (${body.files.length} files${body.platform_name ? ", " + body.platform_name : ""}).`));
        ok.hidden = false;
        for (const o of setsSelect.options) o.selected = false;
        const opt = el("option", {value: body.id}, `${body.name || body.id.slice(0, 8)} · ${body.platform_name || ""} · new`);
        opt.selected = true;
        setsSelect.prepend(opt);
      } catch (e) {
        showProblem(box, e.problem || {title: String(e)});
      } finally {
        busy.hidden = true; bar.hidden = true; button.disabled = false;
      }
    });

    jobForm.addEventListener("submit", async (ev) => {
      ev.preventDefault();
      jobProblem.hidden = true;
      let cfg;
      try {
        cfg = config.value.trim() ? JSON.parse(config.value) : {};
      } catch (e) {
        showProblem(jobProblem, {title: "Configuration is not valid JSON", detail: String(e.message || e), field: "config"});
        return;
      }
      const ids = Array.from(setsSelect.selectedOptions).map((o) => o.value);
      const button = document.getElementById("submit-job");
      button.disabled = true;
      try {
        const {body} = await api("POST", "/v1/jobs", {type: typeSelect.value, observation_set_ids: ids, config: cfg});
        window.location.assign(`/ui/jobs/${body.id}`);
      } catch (e) {
        showProblem(jobProblem, e.problem || {title: String(e)});
        button.disabled = false;
      }
    });
  }

  /* --- PCV map page: polar view of a map, readout of the bin under the pointer ----------------------- */
  function binEdges(centres) {
    // edges halfway between bin centres, the outer ones half a spacing beyond the first and last centre
    const n = centres.length, e = new Array(n + 1);
    for (let i = 1; i < n; i++) e[i] = (centres[i - 1] + centres[i]) / 2;
    const d0 = n > 1 ? centres[1] - centres[0] : 1, d1 = n > 1 ? centres[n - 1] - centres[n - 2] : 1;
    e[0] = centres[0] - d0 / 2; e[n] = centres[n - 1] + d1 / 2;
    return e;
  }

  function findBin(edges, x) {
    for (let i = 0; i < edges.length - 1; i++) if (x >= edges[i] && x < edges[i + 1]) return i;
    return -1;
  }

  function divergingColour(t) {
    // t in [-1, 1]: blue (negative) - white (0) - red (positive)
    const c = Math.max(-1, Math.min(1, t));
    const a = Math.abs(c), w = 255 * (1 - a);
    return c < 0 ? `rgb(${Math.round(w + 33 * a)},${Math.round(w + 102 * a)},${Math.round(w + 172 * a)})`
                 : `rgb(${Math.round(w + 178 * a)},${Math.round(w + 24 * a)},${Math.round(w + 43 * a)})`;
  }

  function wirePcvMap() {
    const canvas = document.getElementById("pcv-polar");
    const dataEl = document.getElementById("pcv-data");
    if (!canvas || !dataEl) return;
    const m = JSON.parse(dataEl.textContent);
    const azEdges = binEdges(m.azimuth_deg), elEdges = binEdges(m.elevation_deg);
    const ctx = canvas.getContext("2d");
    const cx = canvas.width / 2, cy = canvas.height / 2, R = canvas.width / 2 - 22;
    const zenMax = 90 - Math.min(0, elEdges[0]);  // the plot reaches the lowest elevation edge
    const radius = (el) => R * (90 - el) / zenMax;
    let vmax = 0;
    for (const row of m.values_mm) for (const v of row) if (v !== null) vmax = Math.max(vmax, Math.abs(v));
    vmax = vmax || 1;
    // azimuth from antenna x (top) clockwise towards antenna y: canvas angle = az - 90 deg
    const ang = (az) => (az - 90) * Math.PI / 180;
    m.elevation_deg.forEach((_, i) => {
      const r0 = radius(elEdges[i + 1]), r1 = radius(elEdges[i]);
      m.azimuth_deg.forEach((__, j) => {
        const v = m.values_mm[i][j];
        ctx.beginPath();
        ctx.arc(cx, cy, r1, ang(azEdges[j]), ang(azEdges[j + 1]));
        ctx.arc(cx, cy, Math.max(r0, 0), ang(azEdges[j + 1]), ang(azEdges[j]), true);
        ctx.closePath();
        ctx.fillStyle = v === null ? "#d5d9de" : divergingColour(v / vmax);
        ctx.fill();
      });
    });
    ctx.strokeStyle = "rgba(29,39,51,.45)"; ctx.fillStyle = "#5f6b78"; ctx.font = "11px sans-serif";
    for (const el of [0, 30, 60]) {
      ctx.beginPath(); ctx.setLineDash(el === 0 ? [] : [3, 3]);
      ctx.arc(cx, cy, radius(el), 0, 2 * Math.PI); ctx.stroke();
      ctx.fillText(`${el}°`, cx + 3, cy - radius(el) + 12);
    }
    ctx.setLineDash([]);
    for (const [az, name] of [[0, "x"], [90, "y"], [180, ""], [270, ""]]) {
      const a = ang(az);
      ctx.beginPath(); ctx.moveTo(cx, cy); ctx.lineTo(cx + R * Math.cos(a), cy + R * Math.sin(a)); ctx.stroke();
      if (name) ctx.fillText(`${name} ${az}°`, cx + (R + 4) * Math.cos(a) - 8, cy + (R + 14) * Math.sin(a) + 4);
    }
    const legend = document.getElementById("pcv-legend");
    const bar = el("span", {class: "pcv-bar"});  // CSSOM, not a style attribute: the CSP allows only 'self' styles
    bar.style.background = `linear-gradient(90deg,${divergingColour(-1)},#fff,${divergingColour(1)})`;
    legend.replaceChildren(document.createTextNode(`${(-vmax).toFixed(1)} mm `), bar,
                           document.createTextNode(` +${vmax.toFixed(1)} mm · grey: empty bin`));
    const readout = document.getElementById("pcv-readout");
    canvas.addEventListener("mousemove", (ev) => {
      const box = canvas.getBoundingClientRect();
      const x = (ev.clientX - box.left) * canvas.width / box.width - cx;
      const y = (ev.clientY - box.top) * canvas.height / box.height - cy;
      const el = 90 - Math.hypot(x, y) / R * zenMax;
      let az = Math.atan2(y, x) * 180 / Math.PI + 90;
      az = ((az % 360) + 360) % 360;
      let j = findBin(azEdges, az);
      if (j < 0) j = findBin(azEdges, az - 360);
      const i = findBin(elEdges, el);
      if (i < 0 || j < 0) { readout.textContent = "outside the map"; delete readout.dataset.bin; return; }
      const v = m.values_mm[i][j], s = m.sigma_mm[i][j], n = m.count[i][j];
      readout.dataset.bin = `${i},${j}`;
      readout.textContent = `azimuth ${m.azimuth_deg[j]}°, elevation ${m.elevation_deg[i]}°: ` +
        (v === null ? `empty (${n} samples)` : `${v.toFixed(2)} ± ${s === null ? "?" : s.toFixed(2)} mm (${n} samples)`);
    });
    canvas.dataset.ready = "1";
  }

  /* A sign-in link carries the key in its fragment (/ui/login?next=...#key=KEY, printed by `make demo`): the
   * fragment never reaches the server or its logs; the page fills the form, forgets the fragment, signs in. */
  function signInFromFragment() {
    const form = document.getElementById("login-form");
    if (!form || !location.hash.startsWith("#key=")) return;
    const key = decodeURIComponent(location.hash.slice(5));
    history.replaceState(null, "", location.pathname + location.search);
    const input = document.getElementById("api_key");
    if (!input || !key) return;
    input.value = key;
    form.submit();
  }

  /* /ui/new: a form that writes platform.json (CONVENTIONS.md) and adds it to the upload's file list. */
  function wirePlatformWriter() {
    const form = document.getElementById("platform-form");
    if (!form) return;
    const body = form.querySelector("#pf-antennas tbody");
    const preview = document.getElementById("pf-preview");
    const problem = document.querySelector(".js-pf-problem");
    const BORESIGHTS = {"-z (zenith for a nadir-pointing body z)": [0, 0, -1], "+z": [0, 0, 1], "+x": [1, 0, 0],
                        "-x": [-1, 0, 0], "+y": [0, 1, 0], "-y": [0, -1, 0]};
    function addRow(id, pos, bore) {
      const tr = el("tr", {class: "pf-antenna"});
      const cell = (input) => { const td = el("td"); td.appendChild(input); tr.appendChild(td); return input; };
      cell(el("input", {type: "text", class: "pf-id", value: id, maxlength: "60", required: ""}));
      for (let i = 0; i < 3; i++) cell(el("input", {type: "number", step: "any", class: `pf-p${i}`, value: String(pos[i])}));
      const sel = cell(el("select", {class: "pf-bore"}));
      for (const [label, v] of Object.entries(BORESIGHTS)) {
        const o = el("option", {value: JSON.stringify(v)}, label);
        if (JSON.stringify(v) === JSON.stringify(bore)) o.selected = true;
        sel.appendChild(o);
      }
      const rm = el("button", {type: "button", class: "link pf-remove"}, "remove");
      rm.addEventListener("click", () => { tr.remove(); update(); });
      cell(rm);
      body.appendChild(tr);
    }
    function doc() {
      const rows = Array.from(body.querySelectorAll("tr.pf-antenna"));
      const antennas = {};
      const errors = [];
      for (const [i, r] of rows.entries()) {
        const id = r.querySelector(".pf-id").value.trim();
        const pos = [0, 1, 2].map((k) => Number(r.querySelector(`.pf-p${k}`).value));
        if (!id) errors.push(`antenna ${i + 1}: give its id (the RINEX MARKER NAME of its file)`);
        else if (antennas[id]) errors.push(`antenna ${id} is listed twice`);
        if (pos.some((v) => !Number.isFinite(v))) errors.push(`antenna ${id || i + 1}: x, y, z must be numbers [m]`);
        antennas[id] = {position_m: pos, boresight: JSON.parse(r.querySelector(".pf-bore").value)};
      }
      const ids = Object.keys(antennas);
      if (ids.length < 2) errors.push("an attitude needs at least two antennas");
      const out = {name: document.getElementById("pf-name").value.trim() || "platform",
                   kind: document.getElementById("pf-kind").value, antennas, master: ids[0],
                   baselines: ids.slice(1).map((b) => [ids[0], b])};
      return {out, errors};
    }
    function update() {
      const {out, errors} = doc();
      const text = JSON.stringify(out, null, 2) + "\n";
      preview.textContent = text;
      problem.hidden = !errors.length;
      problem.textContent = errors.join("; ");
      const link = document.getElementById("pf-download");
      if (link.dataset.url) URL.revokeObjectURL(link.dataset.url);
      link.dataset.url = URL.createObjectURL(new Blob([text], {type: "application/json"}));
      link.href = link.dataset.url;
      return {text, errors};
    }
    addRow("GPS-2", [0, 0, 0], [0, 0, -1]);
    addRow("GPS-0", [1.0, 0, 0], [0, 0, -1]);
    addRow("GPS-1", [0, 1.0, 0], [0, 0, -1]);
    form.addEventListener("input", update);
    form.addEventListener("change", update);
    document.getElementById("pf-add").addEventListener("click", () => { addRow(`ANT-${body.children.length + 1}`, [0, 0, 0], [0, 0, -1]); update(); });
    document.getElementById("pf-use").addEventListener("click", () => {
      const {text, errors} = update();
      if (errors.length) return;
      const input = document.getElementById("set-files");
      const dt = new DataTransfer();
      for (const f of Array.from(input.files || [])) if (f.name !== "platform.json") dt.items.add(f);
      dt.items.add(new File([text], "platform.json", {type: "application/json"}));
      input.files = dt.files;
      input.dispatchEvent(new Event("change"));
      document.getElementById("pf-use").textContent = "platform.json added to the upload ✓";
    });
    update();
  }

  window.gnssatt = {api, showProblem};
  signInFromFragment();
  wirePlatformWriter();
  startLiveProgress();
  wireCancel();
  wireDelete();
  wireNewPage();
  wirePcvMap();
})();
