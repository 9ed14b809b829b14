// volcal capture page: renders the state pushed by the capture (server-sent events),
// posts typed readings. No library, nothing loaded from elsewhere.
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  let measurements = [];
  let last = null;
  let pageLost = false;

  function fmt(v, nd) {
    return (v === null || v === undefined) ? "–" : Number(v).toFixed(nd);
  }
  function text(el, s) { if (el.textContent !== s) el.textContent = s; }

  function currentMeasurement(s) {
    return measurements.find((m) => m.id === s.current) || measurements[0] || null;
  }

  function renderBanners(s) {
    const box = $("banners");
    const list = (s.banners || []).slice();
    if (pageLost) {
      list.unshift(s.finished ? "volcal capture has ended (" + s.finished + "): this page no longer updates"
        : "The page lost its connection to volcal capture (retrying)");
    }
    const html = list.map((b) => "<div class=\"banner\"></div>");
    if (box.children.length !== list.length) box.innerHTML = html.join("");
    list.forEach((b, i) => text(box.children[i], b));
    // a banner per source, addressable by tests and assistive technology
    box.dataset.control = s.control && s.control.stale ? "stale" : "ok";
    box.dataset.laser = s.laser && s.laser.stale ? "stale" : "ok";
  }

  function renderLive(s) {
    text($("title"), s.title ? "Capture: " + s.title : "volcal capture");
    const c = s.counts || {};
    text($("progress"), (s.finished ? s.finished + " — " : "") + (c.accepted || 0) + " accepted, " +
      (c.missed || 0) + " missed of " + (c.planned || 0) + " planned");
    text($("current"), s.current || "–");
    text($("expected"), s.expected === null || s.expected === undefined ? "–" :
      String(s.expected + 1));
    text($("control-source"), s.control.source || "");
    text($("laser-source"), s.laser.source || "");
    const tb = $("control-pos").tBodies[0];
    const pos = s.control.positions || {};
    const keys = Object.keys(pos).sort();
    if (tb.rows.length !== keys.length) {
      tb.innerHTML = keys.map(() => "<tr><td></td><td></td></tr>").join("");
    }
    keys.forEach((k, i) => {
      text(tb.rows[i].cells[0], k);
      text(tb.rows[i].cells[1], fmt(pos[k], 4) + ("ABC".includes(k) ? " deg" : " mm"));
    });
    const unit = s.laser.unit || "";
    text($("laser-value"), s.laser.value === null ? "–" :
      (s.laser.channels ? s.laser.channels.map((v) => fmt(v, 3)).join(" / ") : fmt(s.laser.value, 3)) + " " + unit);
    const st = s.stability || {};
    const el = $("stability");
    el.className = "stability " + String(st.state || "waiting").replace(/ /g, "-");
    text($("stability-text"), st.state || "waiting");
    const bits = [];
    if (st.distance_mm !== null && st.distance_mm !== undefined) bits.push("to target " + fmt(st.distance_mm, 3) + " mm");
    if (st.control_spread_mm !== null && st.control_spread_mm !== undefined) bits.push("control ±" + fmt(st.control_spread_mm / 2, 4) + " mm");
    if (st.laser_spread !== null && st.laser_spread !== undefined) bits.push("laser ±" + fmt(st.laser_spread / 2, 3));
    text($("stability-detail"), bits.join(", "));
    const form = $("typed-form");
    form.hidden = !s.laser.typed;
    const log = $("typed-log");
    const entries = (s.typed_log || []).slice().reverse();
    if (log.children.length !== entries.length) log.innerHTML = entries.map(() => "<li></li>").join("");
    entries.forEach((e, i) => text(log.children[i], fmt(e.value, 4) + " " + e.unit + " — " + e.state +
      (e.expected !== null && e.expected !== undefined ? " (reading " + (e.expected + 1) + ")" : "")));
    const notes = $("notes");
    const ns = (s.notes || []).slice().reverse();
    if (notes.children.length !== ns.length || (ns[0] && notes.children[0].textContent !== ns[0].text)) {
      notes.innerHTML = "";
      ns.forEach((n) => { const li = document.createElement("li"); li.textContent = n.text; notes.appendChild(li); });
    }
  }

  function renderTable(s) {
    const m = currentMeasurement(s);
    const tb = $("points").tBodies[0];
    if (!m) { tb.innerHTML = ""; return; }
    const rows = m.dwells;
    const axes = m.axes && m.axes.length ? m.axes : ["X", "Y", "Z"];  // one column per axis
    const ncol = axes.length + 5;
    if (tb.dataset.measurement !== m.id || tb.rows.length !== rows.length + 1) {
      tb.dataset.measurement = m.id;
      $("points").tHead.rows[0].innerHTML = "<th>#</th>" +
        axes.map(() => "<th></th>").join("") + "<th>run</th><th>dir</th><th>status</th><th>reading</th>";
      axes.forEach((a, j) => text($("points").tHead.rows[0].cells[j + 1],
        a + ("ABC".includes(a) ? " [deg]" : " [mm]")));
      tb.innerHTML = `<tr class="group"><td colspan="${ncol}"></td></tr>` +
        rows.map(() => "<tr>" + "<td></td>".repeat(ncol) + "</tr>").join("");
      text(tb.rows[0].cells[0], m.id + ": " + rows.length + " readings, " +
        ((m.columns && m.columns.length > 1 ? m.columns.join(" / ") : m.column) || "reading") +
        " [" + m.unit + "]");
      $("typed-unit").value = m.unit === "urad" ? "urad" : "um";  // the measurement's unit
    }
    rows.forEach((d, i) => {
      const tr = tb.rows[i + 1];
      tr.id = "row-" + m.id + "-" + d.reading;
      const cls = d.status + (s.expected === d.reading && s.current === m.id ? " expected" : "");
      if (tr.className !== cls) tr.className = cls;
      tr.dataset.reading = d.reading;
      const cells = [String(d.reading + 1), ...axes.map((_, j) => fmt(d.target[j], 3)),
        d.run === null || d.run === undefined ? "" : String(d.run), d.direction || "", d.status,
        d.value === null ? (d.reason && d.status === "missed" ? d.reason : "") :
          (d.values ? d.values.map((v) => fmt(v, 3)).join(" / ") : fmt(d.value, 3)) + " " + m.unit];
      cells.forEach((v, j) => text(tr.cells[j], v));
      tr.title = d.reason || "";
    });
  }

  function renderPlot(s) {
    const svg = $("plot");
    const m = currentMeasurement(s);
    const W = 600, H = 300, L = 56, R = 12, T = 12, B = 36;
    if (!m) { svg.innerHTML = ""; return; }
    text($("plot-unit"), "[" + m.unit + "] against " + ({
      deg: "the angle from the first target [deg]",
      "mm+deg": "the pose"}[m.axes_unit] || "position along the line [mm]"));
    const all = m.dwells;
    const pts = all.filter((d) => d.status === "accepted" && d.value !== null);
    const xs = all.map((d) => d.along);
    let x0 = Math.min(...xs), x1 = Math.max(...xs);
    if (!(x1 > x0)) { x0 -= 1; x1 += 1; }
    let y0 = Math.min(0, ...pts.map((d) => d.value)), y1 = Math.max(0, ...pts.map((d) => d.value));
    if (!(y1 > y0)) { y0 -= 1; y1 += 1; }
    const pad = 0.08 * (y1 - y0); y0 -= pad; y1 += pad;
    const px = (x) => L + (x - x0) / (x1 - x0) * (W - L - R);
    const py = (y) => T + (y1 - y) / (y1 - y0) * (H - T - B);
    const parts = [];
    for (let k = 0; k <= 4; k++) {
      const y = y0 + k * (y1 - y0) / 4;
      parts.push(`<line class="grid" x1="${L}" x2="${W - R}" y1="${py(y)}" y2="${py(y)}"/>` +
        `<text x="${L - 6}" y="${py(y) + 4}" text-anchor="end">${y.toFixed(Math.abs(y1 - y0) < 5 ? 2 : 1)}</text>`);
      const x = x0 + k * (x1 - x0) / 4;
      parts.push(`<text x="${px(x)}" y="${H - B + 16}" text-anchor="middle">${x.toFixed(0)}</text>`);
    }
    parts.push(`<line class="axis" x1="${L}" x2="${W - R}" y1="${py(0)}" y2="${py(0)}"/>`);
    const series = {};
    pts.forEach((d) => {
      const key = (d.direction || "+") + "|" + (d.run === null || d.run === undefined ? "" : d.run);
      (series[key] = series[key] || []).push(d);
    });
    Object.keys(series).forEach((key) => {
      const cls = key[0] === "-" ? "minus" : "plus";
      const ds = series[key].slice().sort((a, b) => a.along - b.along);
      if (ds.length > 1) {
        parts.push(`<polyline class="line-${cls}" points="${ds.map((d) => px(d.along) + "," + py(d.value)).join(" ")}"/>`);
      }
      ds.forEach((d) => parts.push(`<circle class="${cls} point" r="4" cx="${px(d.along)}" cy="${py(d.value)}" data-reading="${d.reading}"/>`));
    });
    svg.innerHTML = parts.join("");
  }

  function connect() {
    const es = new EventSource("/events");
    es.onmessage = (e) => {
      pageLost = false;
      const prev = last;
      const s = JSON.parse(e.data);
      if (s.measurements) measurements = s.measurements;
      renderBanners(s);
      renderLive(s);
      if (s.measurements || !prev || prev.current !== s.current || prev.expected !== s.expected) {
        renderTable(s);
        renderPlot(s);
      }
      last = s;
    };
    es.onerror = () => {
      pageLost = true;
      if (last) renderBanners(last);
    };
  }

  function setupTyped() {
    $("typed-form").addEventListener("submit", async (ev) => {
      ev.preventDefault();
      const input = $("typed-value");
      const raw = input.value.trim().replace(",", ".");
      const msg = $("typed-message");
      if (raw === "" || !isFinite(Number(raw))) { msg.textContent = "Type a number"; return; }
      try {
        const r = await fetch("/api/typed", {
          method: "POST", headers: { "Content-Type": "application/json" },
          body: JSON.stringify({ value: Number(raw), unit: $("typed-unit").value }),
        });
        const body = await r.json();
        if (!r.ok) { msg.textContent = body.error || ("error " + r.status); return; }
        msg.textContent = "Sent " + body.value + " " + body.unit + " (#" + body.id + ")";
        input.value = "";
      } catch (e) {
        msg.textContent = "Not sent: " + e;
      }
    });
  }

  setupTyped();
  connect();
})();
