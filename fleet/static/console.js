// The console's live updates (issue 29): follows GET /api/events (the session cookie
// authenticates it) and, when anything happens, re-fetches each live section of the page
// (its data-live URL) and replaces its inside. No framework, no build step. On the site map a
// "robots" event (staff) moves the robots' markers at once, by the rule the server draws them
// with (fleet/console/site_svg.py).
"use strict";

(function () {
  const sections = () => Array.from(document.querySelectorAll("section[data-live]"));
  let pending = null;

  async function refresh(section) {
    // A person choosing in a form of this section keeps it; it is fetched after they leave.
    if (section.contains(document.activeElement) && document.activeElement.tagName === "SELECT") {
      schedule(1000);
      return;
    }
    const response = await fetch(section.dataset.live, { credentials: "same-origin" });
    if (response.status === 401) { window.location.assign("/login"); return; }
    if (!response.ok) return;
    section.querySelector(".live").innerHTML = await response.text();
  }

  function refreshAll() {
    pending = null;
    Promise.all(sections().map(refresh))
      .then(() => {
        document.body.dataset.refreshed = String(Date.now());
        // A section waiting for what no event announces (a robot's scale) asks again.
        const waiting = document.querySelector("[data-refresh-ms]");
        if (waiting !== null) schedule(Number(waiting.dataset.refreshMs) || 2000);
      })
      .catch(() => schedule(2000));
  }

  function schedule(delayMs) {
    // Events come in bursts (one status change may notify customer and staff): one fetch.
    if (pending === null) pending = window.setTimeout(refreshAll, delayMs);
  }

  // Server-Sent Events read with fetch: EventSource only delivers events by their name, and
  // every notification kind is a name of its own.
  async function listen() {
    // Staff pages also follow the robots (their state, place and fault: the site map), the
    // customer's page its requests' statuses (not every change notifies the customer).
    const follow = document.body.dataset.follow;
    const url = follow ? `/api/events?${follow}=true` : "/api/events";
    const response = await fetch(url, {
      credentials: "same-origin", headers: { Accept: "text/event-stream" } });
    if (response.status === 401) { window.location.assign("/login"); return false; }
    if (!response.ok || response.body === null) return true;
    const reader = response.body.getReader();
    const decoder = new TextDecoder();
    let buffer = "";
    for (;;) {
      const { value, done } = await reader.read();
      if (done) return true;
      buffer += decoder.decode(value, { stream: true });
      let end;
      while ((end = buffer.indexOf("\n\n")) >= 0) {
        const block = buffer.slice(0, end);
        buffer = buffer.slice(end + 2);
        if (block.startsWith(": subscribed")) {
          document.body.dataset.live = "subscribed";
          schedule(0); // whatever happened while not subscribed
        } else if (block.split("\n").some((line) => line.startsWith("data:"))) {
          if (block.startsWith("event: robots\n")) moveRobots(block);
          schedule(50);
        }
      }
    }
  }

  async function follow() {
    for (;;) {
      let again = true;
      try { again = await listen(); } catch (_err) { again = true; }
      document.body.dataset.live = "reconnecting";
      if (!again) return;
      await new Promise((resolve) => window.setTimeout(resolve, 2000));
    }
  }

  const SVG = "http://www.w3.org/2000/svg";
  const ON_THE_WAY = " -> ";
  const QUEUE_STEP = 0.025;

  function loopPoint(loop, t) {
    const [x0, y0, x1, y1] = loop;
    const w = x1 - x0, h = y1 - y0;
    const d = (((t % 1) + 1) % 1) * 2 * (w + h);
    if (d < w) return [x0 + d, y1];
    if (d < w + h) return [x1, y1 - (d - w)];
    if (d < 2 * w + h) return [x1 - (d - w - h), y0];
    return [x0, y0 + (d - 2 * w - h)];
  }

  function newMarker(svg, name) {
    const g = document.createElementNS(SVG, "g");
    g.id = "marker-" + name;
    g.dataset.robot = name;
    const circle = document.createElementNS(SVG, "circle");
    circle.setAttribute("r", "11");
    const label = document.createElementNS(SVG, "text");
    label.setAttribute("class", "name");
    label.setAttribute("y", "-16");
    label.textContent = name;
    const about = document.createElementNS(SVG, "text");
    about.setAttribute("class", "about");
    about.setAttribute("x", "16");
    about.setAttribute("y", "5");
    // On a map picture the marker is drawn at the picture's scale (site_svg.glyph_scale).
    const glyph = document.createElementNS(SVG, "g");
    glyph.setAttribute("class", "glyph");
    glyph.setAttribute("transform", `scale(${svg.dataset.glyphScale || 1})`);
    glyph.append(circle, label, about);
    g.appendChild(glyph);
    svg.appendChild(g);
    return g;
  }

  function update(svg, robot) {
    const g = document.getElementById("marker-" + robot.Name) || newMarker(svg, robot.Name);
    g.setAttribute("class", "robot c-" + robot.Condition);
    g.dataset.condition = robot.Condition;
    g.dataset.place = robot.Place || "";
    if (robot.X !== null && robot.Y !== null) {
      g.dataset.x = robot.X;
      g.dataset.y = robot.Y;
      g.dataset.theta = robot.Theta === null ? 0 : robot.Theta;
      g.dataset.map = robot.Map || "";
    } else delete g.dataset.x;
    const battery = robot.BatteryPct === null ? "" : Math.round(robot.BatteryPct) + "%";
    g.querySelector("text.about").textContent = [battery, robot.FaultCode || ""].join(" ").trim();
  }

  function layoutSchematic(svg) {
    const loop = svg.dataset.loop.split(",").map(Number);
    const rooms = {};
    svg.querySelectorAll("g.room").forEach((r) => { rooms[r.dataset.room] = Number(r.dataset.t); });
    const at = {};
    svg.querySelectorAll("g.robot").forEach((g) => {
      const place = g.dataset.place || "";
      const cut = place.indexOf(ON_THE_WAY);
      const origin = cut >= 0 ? place.slice(0, cut) : null;
      const target = cut >= 0 ? place.slice(cut + ON_THE_WAY.length) : place;
      const index = at[place] || 0;
      at[place] = index + 1;
      if (!(target in rooms)) { g.style.display = "none"; return; }
      const end = rooms[target];
      let t;
      if (origin === null) t = end - index * QUEUE_STEP;
      else {
        const start = origin in rooms ? rooms[origin] : end - 4 * QUEUE_STEP;
        t = start + ((((end - start) % 1) + 1) % 1) / 2;
      }
      const [x, y] = loopPoint(loop, t);
      g.style.display = "";
      g.setAttribute("transform", `translate(${x.toFixed(1)},${y.toFixed(1)})`);
    });
  }

  // A pose on the site map's own map, or on "odom" for a robot whose odometry frame the site
  // file places (site_svg.on_site_map); null: not on this picture.
  function onSiteMap(svg, g) {
    if (g.dataset.x === undefined) return null;
    const [x, y, theta] = [g.dataset.x, g.dataset.y, g.dataset.theta].map(Number);
    if (g.dataset.map === svg.dataset.map) return [x, y, theta];
    const placed = JSON.parse(svg.dataset.placements || "{}")[g.dataset.robot];
    if (g.dataset.map !== "odom" || placed === undefined) return null;
    const [px, py, pt] = placed;
    const c = Math.cos(pt), s = Math.sin(pt);
    return [px + c * x - s * y, py + s * x + c * y, pt + theta];
  }

  function layoutPicture(svg) {
    const [ox, oy] = svg.dataset.origin.split(",").map(Number);
    const resolution = Number(svg.dataset.resolution);
    const height = Number(svg.dataset.height);
    svg.querySelectorAll("g.robot").forEach((g) => {
      if (g.dataset.x === undefined && g.dataset.map === undefined) return;  // drawn as served
      const pose = onSiteMap(svg, g);
      if (pose === null) { g.style.display = "none"; return; }
      const x = (pose[0] - ox) / resolution;
      const y = height - (pose[1] - oy) / resolution;
      g.style.display = "";
      g.setAttribute("transform", `translate(${x.toFixed(1)},${y.toFixed(1)})`);
      let heading = g.querySelector("line.heading");
      if (heading === null) {
        heading = document.createElementNS(SVG, "line");
        heading.setAttribute("class", "heading");
        heading.setAttribute("x1", "0");
        heading.setAttribute("y1", "0");
        const glyph = g.querySelector("g.glyph") || g;
        glyph.insertBefore(heading, glyph.firstChild);
      }
      heading.setAttribute("x2", (22 * Math.cos(pose[2])).toFixed(1));
      heading.setAttribute("y2", (-22 * Math.sin(pose[2])).toFixed(1));
    });
  }

  function moveRobots(block) {
    const svg = document.getElementById("site-map");
    if (svg === null) return;
    const line = block.split("\n").find((l) => l.startsWith("data:"));
    let robots;
    try { robots = JSON.parse(line.slice(5)).Robots; } catch (_err) { return; }
    robots.forEach((robot) => update(svg, robot));
    if (svg.classList.contains("schematic")) layoutSchematic(svg); else layoutPicture(svg);
    document.body.dataset.robotsMoved = String(Number(document.body.dataset.robotsMoved || 0) + 1);
  }

  if (sections().length > 0) follow();
})();
