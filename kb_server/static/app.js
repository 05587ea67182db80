// urdfkb pages: upload with live job progress, review corrections, SPARQL editor. Same-origin fetch only.
"use strict";

const $ = (sel, root = document) => root.querySelector(sel);

// --- who is reviewing, and the server's token (kept in this browser only) ---------------------
for (const id of ["reviewer", "token"]) {
  const input = document.getElementById(id);
  if (!input) continue;
  input.value = localStorage.getItem("urdfkb." + id) || "";
  input.addEventListener("change", () => localStorage.setItem("urdfkb." + id, input.value.trim()));
}

function authHeaders(extra = {}) {
  const token = localStorage.getItem("urdfkb.token");
  return token ? { ...extra, Authorization: "Bearer " + token } : extra;
}

function say(text, isError) {
  const box = document.getElementById("message");
  if (!box) return;
  box.textContent = text;
  box.className = "message" + (isError ? " error" : " ok");
}

async function errorText(resp) {
  try { return (await resp.json()).error || resp.statusText; } catch (e) { return resp.statusText; }
}

// --- index: upload a URDF or xacro and follow its job ---------------------------------------
const upload = document.getElementById("upload");
if (upload) {
  upload.addEventListener("submit", async (event) => {
    event.preventDefault();
    const form = new FormData(upload);
    for (const [key, value] of [...form.entries()]) if (value === "") form.delete(key);
    const job = document.getElementById("job");
    job.hidden = false;
    $("#job-result").textContent = "";
    const resp = await fetch("/populate", { method: "POST", body: form, headers: authHeaders() });
    if (resp.status !== 202) {
      $("#job-state").textContent = "refused";
      $("#job-result").textContent = await errorText(resp);
      $("#job-result").className = "error";
      return;
    }
    follow((await resp.json()).id);
  });
}

async function follow(id) {
  for (;;) {
    const job = await (await fetch("/jobs/" + id)).json();
    $("#job-state").textContent = job.state;
    $("#job-stage").textContent = job.stage;
    const { done, total } = job.progress;
    $("#job-count").textContent = total ? `${done}/${total}` : "";
    $("#job-progress").max = total || 1;
    $("#job-progress").value = total ? done : 0;
    if (["succeeded", "failed", "mirror_failed"].includes(job.state)) return finished(job);
    await new Promise((r) => setTimeout(r, 400));
  }
}

function finished(job) {
  const out = $("#job-result");
  out.textContent = "";
  if (job.state === "failed") {
    out.className = "error";
    out.textContent = job.errors.join("\n");
    return;
  }
  out.className = "ok";
  const link = document.createElement("a");
  link.href = "/robots/" + encodeURIComponent(job.robot);
  link.id = "job-robot";
  link.textContent = "Open " + job.robot;
  out.append(link);
  const c = job.corrections || { applied: [], stale: [] };
  if (c.applied.length || c.stale.length) {
    const list = document.createElement("ul");
    list.id = "job-corrections";
    for (const a of c.applied) list.append(item(`re-applied: ${a.summary} (${a.reviewer})`));
    for (const s of c.stale) list.append(item(`no longer fits: ${s.summary}: ${s.reason}`));
    out.append(list);
  }
  for (const e of job.errors) out.append(item(e));
}

function item(text) {
  const li = document.createElement("li");
  li.textContent = text;
  return li;
}

// --- robot page: corrections of components and body parts ---------------------------------
const robot = document.getElementById("robot");
if (robot) {
  const name = robot.dataset.robot;

  async function correct(body) {
    body.reviewer = localStorage.getItem("urdfkb.reviewer") || "";
    const resp = await fetch(`/robots/${encodeURIComponent(name)}/corrections`, {
      method: "POST", body: JSON.stringify(body),
      headers: authHeaders({ "Content-Type": "application/json", Accept: "application/json" }),
    });
    if (resp.status === 201) {
      location.reload();
    } else {
      say(await errorText(resp), true);
    }
  }

  robot.addEventListener("click", (event) => {
    const part = event.target.closest("button[data-body]");
    if (part) {
      const row = part.closest("tr");
      const body = { part: row.dataset.part, action: part.dataset.body };
      const field = { reclassify: ["class", ".part-class"], side: ["side", ".part-side"],
                      merge: ["with", ".part-with"], split: ["at", ".part-at"] }[body.action];
      if (field) body[field[0]] = $(field[1], row).value;
      if (body.action === "reject" && !confirm("Reject this body part (not a part of the body)?")) return;
      correct(body);
      return;
    }
    const button = event.target.closest("button[data-action]");
    if (button) {
      const row = button.closest("tr");
      const body = { action: button.dataset.action, links: JSON.parse(row.dataset.linkset) };
      if (body.action === "reclassify") body.class = $(".class-choice", row).value;
      if (body.action === "remount") body.mount = $(".mount-choice", row).value;
      if (body.action === "reject" && !confirm("Reject this component (not a component)?")) return;
      correct(body);
      return;
    }
    const outline = event.target.closest("g.component, g.body-part");
    if (outline) {
      const row = document.getElementById("row-" + (outline.dataset.component || outline.dataset.part));
      if (row) {
        row.scrollIntoView({ block: "center" });
        row.classList.add("flash");
        setTimeout(() => row.classList.remove("flash"), 1200);
      }
    }
  });

  const again = document.getElementById("repopulate");
  if (again) {
    again.addEventListener("click", async () => {
      document.getElementById("job").hidden = false;
      const resp = await fetch(`/robots/${encodeURIComponent(name)}/populate`, { method: "POST", headers: authHeaders() });
      if (resp.status !== 202) return say(await errorText(resp), true);
      follow((await resp.json()).id);
    });
  }

  const add = document.getElementById("add");
  if (add) {
    add.addEventListener("submit", (event) => {
      event.preventDefault();
      const links = [...$("#add-links").selectedOptions].map((o) => o.value);
      if (!links.length) return say("Select the links of the missed component first.", true);
      correct({ action: "add", links, class: $("#add-class").value, mount: $("#add-mount").value.trim() });
    });
  }
}

// --- SPARQL page ---------------------------------------------------------------------------
const sparql = document.getElementById("sparql");
if (sparql) {
  const presets = JSON.parse(document.getElementById("presets").textContent);
  $("#preset").addEventListener("change", (e) => { $("#query").value = presets[e.target.value].text; });
  sparql.addEventListener("submit", async (event) => {
    event.preventDefault();
    say("running…");
    const started = performance.now();
    const resp = await fetch("/sparql", {
      method: "POST", body: new URLSearchParams({ query: $("#query").value }),
      headers: { Accept: "application/sparql-results+json, text/turtle;q=0.9" },
    });
    const results = $("#results");
    results.textContent = "";
    if (!resp.ok) return say(await resp.text(), true);
    const ms = Math.round(performance.now() - started);
    if ((resp.headers.get("Content-Type") || "").startsWith("text/turtle")) {
      const pre = document.createElement("pre");
      pre.textContent = await resp.text();
      results.append(pre);
      return say(`graph in ${ms} ms`);
    }
    const data = await resp.json();
    if ("boolean" in data) return say(`answer: ${data.boolean} (${ms} ms)`);
    const vars = data.head.vars;
    const table = document.createElement("table");
    table.className = "grid";
    table.id = "result-table";
    const head = table.createTHead().insertRow();
    for (const v of vars) head.append(Object.assign(document.createElement("th"), { textContent: v }));
    const body = table.createTBody();
    for (const b of data.results.bindings) {
      const row = body.insertRow();
      for (const v of vars) {
        const cell = row.insertCell();
        const term = b[v];
        if (!term) continue;
        cell.textContent = term.type === "uri" ? term.value.replace(/^.*[#/]/, "") : term.value;
        cell.title = term.value;
      }
    }
    results.append(table);
    const n = data.results.bindings.length;
    say(`${n} row${n === 1 ? "" : "s"} in ${ms} ms`);
  });
}
