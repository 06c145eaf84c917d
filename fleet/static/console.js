// The console's live updates (issue 29): follows GET /api/events (the session cookie
// authenticates it) and, when anything happens, re-fetches each live section of the page
// (its data-live URL) and replaces its inside. No framework, no build step.
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
    const response = await fetch("/api/events", {
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

  if (sections().length > 0) follow();
})();
