// stackdsl's replay page (stackdsl/draw/replay.py writes it): a recorded run played with three.js.
// A body's pose at time t is that of its last row at or before the last frame at or before t,
// as stackdsl.Trajectory.at(t); the ground and the fixtures bolted to it are moved by the
// ground's offset at that frame (a shake). Source: stackdsl's own.
"use strict";
(function () {
  const api = (window.stackdslReplay = { ready: false, error: null, loadMs: null });
  const $ = (id) => document.getElementById(id);

  function bytes(text) {
    const raw = atob(text);
    const out = new Uint8Array(raw.length);
    for (let i = 0; i < raw.length; i++) out[i] = raw.charCodeAt(i);
    return out;
  }

  async function inflate(id) {
    const stream = new Blob([bytes($(id).textContent.trim())]).stream().pipeThrough(new DecompressionStream("gzip"));
    return await new Response(stream).text();
  }

  function moduleUrl(text) {
    return URL.createObjectURL(new Blob([text], { type: "text/javascript" }));
  }

  // the vendored three.js and its orbit controls, imported from blob: addresses (no network)
  async function loadThree() {
    const threeUrl = moduleUrl(await inflate("three-gz"));
    const orbit = (await inflate("orbit-gz")).replace(/from\s+['"]three['"]/g, `from '${threeUrl}'`);
    const THREE = await import(threeUrl);
    const { OrbitControls } = await import(moduleUrl(orbit));
    return { THREE, OrbitControls };
  }

  function fmt(x, digits) {
    return Number(x).toFixed(digits);
  }

  function escapeHtml(text) {
    return String(text).replace(/[&<>"']/g, (c) => ({ "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" })[c]);
  }

  async function start() {
    const data = JSON.parse($("replay-data").textContent);
    const { THREE, OrbitControls } = await loadThree();

    // -- the trajectory ----------------------------------------------------------------------
    const ids = data.ids;
    const n = ids.length;
    const times = new Float64Array(bytes(data.times).buffer);
    const rowFrame = new Int32Array(bytes(data.row_frame).buffer);
    const rowBody = new Int32Array(bytes(data.row_body).buffer);
    const rowPos = new Float32Array(bytes(data.row_position).buffer);
    const rowQuat = new Float32Array(bytes(data.row_orientation).buffer);
    const rowState = bytes(data.row_state);
    // the ground's offset at each frame (x, y, z): a shake moves the ground and the fixtures on it
    const groundOffset = data.ground_offset ? new Float32Array(bytes(data.ground_offset).buffer) : new Float32Array(3 * times.length);
    const index = new Map(ids.map((id, i) => [id, i]));
    // each body's rows, in frame order (rows are stored in frame order)
    const counts = new Int32Array(n);
    for (let r = 0; r < rowBody.length; r++) counts[rowBody[r]]++;
    const bodyRows = Array.from(counts, (c) => new Int32Array(c));
    counts.fill(0);
    for (let r = 0; r < rowBody.length; r++) bodyRows[rowBody[r]][counts[rowBody[r]]++] = r;
    const ABSENT = 0;

    function frameIndex(t) {
      // the last frame at or before t (the first frame for earlier times)
      let lo = 0;
      let hi = times.length;
      while (lo < hi) {
        const mid = (lo + hi) >> 1;
        if (times[mid] <= t + 1e-9) lo = mid + 1;
        else hi = mid;
      }
      return Math.max(0, lo - 1);
    }

    function rowAt(body, frame) {
      // the body's last row at or before frame, or -1
      const rows = bodyRows[body];
      let lo = 0;
      let hi = rows.length;
      while (lo < hi) {
        const mid = (lo + hi) >> 1;
        if (rowFrame[rows[mid]] <= frame) lo = mid + 1;
        else hi = mid;
      }
      return lo ? rows[lo - 1] : -1;
    }

    // -- the scene ---------------------------------------------------------------------------
    const view = $("view");
    const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(new THREE.Color(data.colours.background));
    view.appendChild(renderer.domElement);
    const scene = new THREE.Scene();
    const camera = new THREE.PerspectiveCamera(35, 1, 0.001, 100);
    camera.up.set(0, 0, 1);
    scene.add(new THREE.HemisphereLight(0xffffff, 0x888877, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.6, -0.9, 1.4);
    scene.add(sun);

    const box = new THREE.BoxGeometry(1, 1, 1);
    const material = new THREE.MeshStandardMaterial({ roughness: 0.75, metalness: 0 });
    const bricks = new THREE.InstancedMesh(box, material, Math.max(n, 1));
    bricks.count = n;
    bricks.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
    scene.add(bricks);
    // every brick's edges, one line geometry moved with the bricks
    const unitEdges = new THREE.EdgesGeometry(box).attributes.position.array;
    const edgeCount = unitEdges.length / 3;
    const edgePositions = new Float32Array(Math.max(n, 1) * unitEdges.length);
    const edgeGeometry = new THREE.BufferGeometry();
    edgeGeometry.setAttribute("position", new THREE.BufferAttribute(edgePositions, 3).setUsage(THREE.DynamicDrawUsage));
    const edges = new THREE.LineSegments(edgeGeometry, new THREE.LineBasicMaterial({ color: 0x333333, transparent: true, opacity: 0.55 }));
    edges.frustumCulled = false;
    scene.add(edges);
    const corner = new THREE.Vector3();
    const colours = {};
    for (const [k, v] of Object.entries(data.colours)) colours[k] = new THREE.Color(v);
    const matrix = new THREE.Matrix4();
    const position = new THREE.Vector3();
    const quaternion = new THREE.Quaternion();
    const scale = new THREE.Vector3();
    const hidden = new THREE.Matrix4().makeScale(0, 0, 0);

    // the fixtures, in a group the ground's offset moves (they are at rest in it)
    const table = new THREE.Group();
    scene.add(table);
    const fixtureMeshes = data.fixtures.map((f) => {
      const mesh = new THREE.Mesh(box, new THREE.MeshStandardMaterial({ color: colours.fixture, roughness: 0.9 }));
      mesh.position.fromArray(f.position);
      mesh.quaternion.fromArray(f.quaternion);
      mesh.scale.set(2 * f.half_extents[0], 2 * f.half_extents[1], 2 * f.half_extents[2]);
      table.add(mesh);
      return mesh;
    });

    // the extent of the structure as placed: each structure brick's first row
    const low = new THREE.Vector3(Infinity, Infinity, 0);
    const high = new THREE.Vector3(-Infinity, -Infinity, -Infinity);
    for (let b = 0; b < n; b++) {
      if (!bodyRows[b].length || data.levels[b] === 0) continue;
      const r = bodyRows[b][0];
      const h = Math.max(...data.half_extents[b]);
      low.min(new THREE.Vector3(rowPos[3 * r] - h, rowPos[3 * r + 1] - h, rowPos[3 * r + 2] - h));
      high.max(new THREE.Vector3(rowPos[3 * r] + h, rowPos[3 * r + 1] + h, rowPos[3 * r + 2] + h));
    }
    if (!isFinite(high.x)) {
      low.set(-0.1, -0.1, 0);
      high.set(0.1, 0.1, 0.1);
    }
    low.z = 0;
    const size = new THREE.Vector3().subVectors(high, low);
    const centre = new THREE.Vector3().addVectors(low, high).multiplyScalar(0.5);
    const span = Math.max(size.x, size.y, size.z, 0.05);

    const groundSize = Math.max(1, 4 * span);
    const ground = new THREE.Mesh(
      new THREE.PlaneGeometry(groundSize, groundSize),
      new THREE.MeshStandardMaterial({ color: colours.ground, roughness: 1 })
    );
    ground.position.set(centre.x, centre.y, -1e-4);
    table.add(ground);
    const grid = new THREE.GridHelper(groundSize, Math.round(groundSize / 0.1), 0xb8b6b0, 0xd4d2cc);
    grid.rotation.x = Math.PI / 2;
    grid.position.set(centre.x, centre.y, 0);
    table.add(grid);

    camera.near = span / 200;
    camera.far = span * 200;
    camera.position.set(centre.x + 1.6 * span, centre.y - 2.2 * span, centre.z + 1.0 * span);
    const controls = new OrbitControls(camera, renderer.domElement);
    controls.target.copy(centre);
    controls.update();
    controls.addEventListener("change", () => draw());

    // the selected brick's outline
    const outline = new THREE.LineSegments(new THREE.EdgesGeometry(box), new THREE.LineBasicMaterial({ color: 0x000000 }));
    outline.visible = false;
    scene.add(outline);

    // the golden's ghosts
    const ghostGroup = new THREE.Group();
    const ghostMaterial = new THREE.MeshBasicMaterial({ color: 0x22dd55, transparent: true, opacity: 0.4, depthWrite: false });
    // the outlines show through the run's bricks
    const ghostEdges = new THREE.LineBasicMaterial({ color: 0x0b7a2a, depthTest: false, transparent: true });
    for (const g of data.ghosts) {
      const mesh = new THREE.Mesh(box, ghostMaterial);
      mesh.position.fromArray(g.position);
      mesh.quaternion.fromArray(g.quaternion);
      mesh.scale.set(2 * g.half_extents[0], 2 * g.half_extents[1], 2 * g.half_extents[2]);
      mesh.userData.id = g.id;
      const lines = new THREE.LineSegments(new THREE.EdgesGeometry(box), ghostEdges);
      lines.renderOrder = 2;
      mesh.add(lines);
      ghostGroup.add(mesh);
    }
    scene.add(ghostGroup);

    function resize() {
      const w = Math.max(view.clientWidth, 1);
      const h = Math.max(view.clientHeight, 1);
      renderer.setSize(w, h, false);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      draw();
    }

    // -- state at a time ---------------------------------------------------------------------
    let now = 0;
    let frame = 0;
    let selected = null;
    const stateOf = new Uint8Array(n);
    const rowOf = new Int32Array(n).fill(-1);

    function apply(k) {
      frame = k;
      if (3 * k + 2 < groundOffset.length) table.position.set(groundOffset[3 * k], groundOffset[3 * k + 1], groundOffset[3 * k + 2]);
      for (let b = 0; b < n; b++) {
        const r = rowAt(b, k);
        rowOf[b] = r;
        stateOf[b] = r < 0 ? ABSENT : rowState[r];
        if (r < 0 || rowState[r] === ABSENT) {
          bricks.setMatrixAt(b, hidden);
          edgePositions.fill(0, b * unitEdges.length, (b + 1) * unitEdges.length);
          continue;
        }
        position.set(rowPos[3 * r], rowPos[3 * r + 1], rowPos[3 * r + 2]);
        quaternion.set(rowQuat[4 * r], rowQuat[4 * r + 1], rowQuat[4 * r + 2], rowQuat[4 * r + 3]);
        const h = data.half_extents[b];
        scale.set(2 * h[0], 2 * h[1], 2 * h[2]);
        matrix.compose(position, quaternion, scale);
        bricks.setMatrixAt(b, matrix);
        for (let v = 0; v < edgeCount; v++) {
          corner.fromArray(unitEdges, 3 * v).applyMatrix4(matrix);
          corner.toArray(edgePositions, b * unitEdges.length + 3 * v);
        }
        const key = data.levels[b] === 0 ? "projectile" : data.states[rowState[r]];
        bricks.setColorAt(b, colours[key] || colours.active);
      }
      bricks.instanceMatrix.needsUpdate = true;
      edgeGeometry.attributes.position.needsUpdate = true;
      if (bricks.instanceColor) bricks.instanceColor.needsUpdate = true;
      bricks.computeBoundingSphere();
      placeOutline();
    }

    function placeOutline() {
      const b = selected === null ? -1 : index.get(selected);
      const r = b === undefined || b < 0 ? -1 : rowOf[b];
      outline.visible = r >= 0;
      if (r < 0) return;
      bricks.getMatrixAt(b, matrix);
      matrix.decompose(outline.position, outline.quaternion, outline.scale);
      outline.scale.multiplyScalar(1.02);
    }

    let pending = false;
    function draw() {
      if (pending) return;
      pending = true;
      requestAnimationFrame(() => {
        pending = false;
        renderer.render(scene, camera);
        api.draws = (api.draws || 0) + 1;
      });
    }

    function seek(t) {
      t = Math.min(Math.max(Number(t) || 0, times.length ? times[0] : 0), data.end);
      now = t;
      const k = frameIndex(t);
      if (k !== frame || !api.ready) apply(k);
      $("scrub").value = String(t);
      $("clock").textContent = `t = ${fmt(t, 3)} s / ${fmt(data.end, 2)} s  frame ${k + 1} of ${times.length}`;
      showEvents(t);
      if (selected !== null) showPanel(selected);
      draw();
      return k;
    }

    // -- events ------------------------------------------------------------------------------
    let anchor = null; // [event time, time landed on] of the last jump to an event
    function seekEvent(t) {
      // an event's moment: its own frame, else the first frame after it (the frame before it
      // shows the scene before the event: a file recorded without a frame at a back-dated collapse)
      const k = frameIndex(t);
      const later = times.length && times[k] < t - 1e-9 && k + 1 < times.length;
      seek(later ? times[k + 1] : t);
      anchor = [t, now];
      return now;
    }
    const events = data.events;
    const keyTimes = events.filter((e) => data.key_events.includes(e.kind)).map((e) => e.time);
    const list = $("events");
    const marks = $("marks");
    const items = events.map((e) => {
      const li = document.createElement("li");
      li.textContent = `${fmt(e.time, 3)} ${e.kind} ${e.brick}${e.level ? " L" + e.level : ""}${e.detail ? " " + e.detail : ""}`;
      li.title = li.textContent;
      if (data.key_events.includes(e.kind)) li.classList.add("keyevent");
      li.addEventListener("click", () => {
        pause();
        seekEvent(e.time);
        if (index.has(e.brick)) select(e.brick);
      });
      list.appendChild(li);
      if (e.kind !== "place" && e.kind !== "freeze") {
        const m = document.createElement("div");
        m.className = `mark ${e.kind}`;
        m.style.left = `${(100 * e.time) / Math.max(data.end, 1e-9)}%`;
        m.title = li.textContent;
        m.addEventListener("click", () => {
          pause();
          seekEvent(e.time);
        });
        marks.appendChild(m);
      }
      return li;
    });
    let currentEvent = -1;
    function showEvents(t) {
      let last = -1;
      for (let i = 0; i < events.length && events[i].time <= t + 1e-9; i++) last = i;
      if (last === currentEvent) return;
      items.forEach((li, i) => {
        li.classList.toggle("past", i < last);
        li.classList.toggle("current", i === last);
      });
      currentEvent = last;
      if (last >= 0) {
        const e = events[last];
        $("status").textContent = `last event: ${fmt(e.time, 3)} s ${e.kind} ${e.brick}${e.level ? " level " + e.level : ""} ${e.detail}`;
        if (!playing) items[last].scrollIntoView({ block: "nearest" });
      } else $("status").textContent = "";
    }
    function eventNow() {
      // the time of the event last jumped to while the page still shows it, else the time shown
      return anchor && anchor[1] === now ? anchor[0] : now;
    }
    function nextEvent() {
      const from = eventNow();
      const e = events.find((e) => e.time > from + 1e-6);
      if (e) seekEvent(e.time);
      else seek(data.end);
      return now;
    }
    function prevEvent() {
      const from = eventNow();
      let t = null;
      for (const e of events) if (e.time < from - 1e-6) t = e.time;
      if (t === null) seek(times.length ? times[0] : 0);
      else seekEvent(t);
      return now;
    }

    // -- the panel of a brick ----------------------------------------------------------------
    function graphAt(t) {
      // the brick graph nearest in time (a run keeps two: at the collapse and at the end)
      let chosen = null;
      for (const g of Object.values(data.graphs)) if (!chosen || Math.abs(g.time - t) < Math.abs(chosen.time - t)) chosen = g;
      return chosen;
    }

    function panelFacts(id) {
      const b = index.get(id);
      const r = rowOf[b];
      const facts = [["level", data.levels[b] === 0 ? "none: thrown or pushing" : String(data.levels[b])]];
      facts.push(["state", data.states[stateOf[b]]]);
      if (r >= 0) {
        const p = [rowPos[3 * r], rowPos[3 * r + 1], rowPos[3 * r + 2]];
        facts.push(["position", p.map((v) => fmt(1000 * v, 1)).join(", ") + " mm"]);
        const e = new THREE.Euler().setFromQuaternion(
          new THREE.Quaternion(rowQuat[4 * r], rowQuat[4 * r + 1], rowQuat[4 * r + 2], rowQuat[4 * r + 3]),
          "ZYX"
        );
        facts.push(["yaw, pitch, roll", [e.z, e.y, e.x].map((v) => fmt((180 * v) / Math.PI, 1)).join(", ") + " deg"]);
        const first = bodyRows[b][0];
        const moved = Math.hypot(rowPos[3 * r] - rowPos[3 * first], rowPos[3 * r + 1] - rowPos[3 * first + 1], rowPos[3 * r + 2] - rowPos[3 * first + 2]);
        facts.push(["moved since placed", fmt(1000 * moved, 1) + " mm (centre)"]);
        facts.push(["recorded", `${fmt(times[rowFrame[r]], 3)} s`]);
      }
      let support = null;
      for (const e of events) {
        if (e.time > now + 1e-9) break;
        if (e.brick === id && (e.kind === "freeze" || e.kind === "wake" || e.kind === "place" || e.kind === "launch")) support = e;
      }
      if (support) facts.push(["last change", `${support.kind} at ${fmt(support.time, 3)} s${support.detail ? ": " + support.detail : ""}`]);
      return facts;
    }

    function showPanel(id) {
      const facts = panelFacts(id);
      $("panel-title").textContent = `${id} at t = ${fmt(now, 3)} s`;
      $("panel-facts").innerHTML = facts.map(([k, v]) => `<tr><td>${escapeHtml(k)}</td><td>${escapeHtml(v)}</td></tr>`).join("");
      const g = graphAt(now);
      const node = g && g.bricks[id];
      let html = "";
      if (node) {
        const edges = node.rests_on.length
          ? node.rests_on.map(([s, area, share]) => `<li>${escapeHtml(s)}: load share ${fmt(share, 3)}, contact ${fmt(area, 1)} mm²</li>`).join("")
          : "<li>nothing</li>";
        html =
          `<p>brick graph ${escapeHtml(g.label)} (t = ${fmt(g.time, 3)} s): ${escapeHtml(node.state)}; ` +
          `centre of mass above ${node.com_above_mm.map((v) => fmt(v, 1)).join(", ")} mm, mass above ${fmt(node.mass_above_g, 1)} g; rests on</p><ul>${edges}</ul>`;
      }
      const ghost = data.ghosts.find((x) => x.id === id);
      if (ghost) html += `<p>golden: ${escapeHtml(ghost.why)}</p>`;
      $("panel-graph").innerHTML = html;
      $("panel").hidden = false;
      return [$("panel-title").textContent, ...facts.map(([k, v]) => `${k}: ${v}`)].join("\n");
    }

    function select(id) {
      if (id === null || id === undefined || !index.has(id)) {
        selected = null;
        $("panel").hidden = true;
        placeOutline();
        draw();
        return null;
      }
      selected = id;
      const text = showPanel(id);
      placeOutline();
      draw();
      return text;
    }

    const raycaster = new THREE.Raycaster();
    function pick(clientX, clientY) {
      const rect = renderer.domElement.getBoundingClientRect();
      const pointer = new THREE.Vector2(((clientX - rect.left) / rect.width) * 2 - 1, -((clientY - rect.top) / rect.height) * 2 + 1);
      raycaster.setFromCamera(pointer, camera);
      const hit = raycaster.intersectObject(bricks, false).find((h) => h.instanceId !== undefined && rowOf[h.instanceId] >= 0);
      return hit ? ids[hit.instanceId] : null;
    }
    let down = null;
    renderer.domElement.addEventListener("pointerdown", (e) => (down = [e.clientX, e.clientY]));
    renderer.domElement.addEventListener("pointerup", (e) => {
      if (down && Math.hypot(e.clientX - down[0], e.clientY - down[1]) < 4) select(pick(e.clientX, e.clientY));
      down = null;
    });

    function screenPosition(id) {
      const b = index.get(id);
      if (b === undefined || rowOf[b] < 0) return null;
      const r = rowOf[b];
      const v = new THREE.Vector3(rowPos[3 * r], rowPos[3 * r + 1], rowPos[3 * r + 2]).project(camera);
      const rect = renderer.domElement.getBoundingClientRect();
      return [rect.left + ((v.x + 1) / 2) * rect.width, rect.top + ((1 - v.y) / 2) * rect.height];
    }

    // -- playback ----------------------------------------------------------------------------
    let playing = false;
    let last = 0;
    const rate = Number(data.meta.rate) || 30;
    function factor() {
      if ($("slow").checked && keyTimes.some((k) => now >= k - 0.1 && now <= k + 0.5)) return 0.2;
      const k = frame;
      const gap = k + 1 < times.length ? times[k + 1] - times[k] : 0;
      return gap > 1.5 / rate ? 10 : 1; // a quiet wait (nothing moves) plays ten times faster
    }
    function advance(dt) {
      // playback over dt wall seconds: the chosen speed, slowed at key events, faster through a quiet
      // wait; never past the next recorded frame out of a quiet wait, nor past the next key event
      const f = factor();
      let target = now + dt * Number($("speed").value) * f;
      if (f > 1 && frame + 1 < times.length) target = Math.min(target, times[frame + 1]);
      const key = keyTimes.find((k) => k > now + 1e-9);
      if (key !== undefined) target = Math.min(target, key);
      seek(target);
      if (playing) $("clock").textContent += f < 1 ? "  slow motion x" + f : f > 1 ? "  quiet, x" + f : "";
      return now;
    }
    function tick(stamp) {
      if (!playing) return;
      const dt = Math.min((stamp - last) / 1000, 0.1);
      last = stamp;
      advance(dt);
      if (now >= data.end) pause();
      else requestAnimationFrame(tick);
    }
    function play() {
      if (playing) return;
      if (now >= data.end) seek(0);
      playing = true;
      $("play").textContent = "pause";
      last = performance.now();
      requestAnimationFrame(tick);
    }
    function pause() {
      playing = false;
      $("play").textContent = "play";
    }
    function stepFrame(d) {
      pause();
      const k = Math.min(Math.max(frame + d, 0), times.length - 1);
      seek(times[k]);
    }

    // -- controls ----------------------------------------------------------------------------
    const scrub = $("scrub");
    scrub.max = String(data.end);
    scrub.step = "any";
    scrub.addEventListener("input", () => {
      pause();
      seek(Number(scrub.value));
    });
    $("play").addEventListener("click", () => (playing ? pause() : play()));
    $("prev-frame").addEventListener("click", () => stepFrame(-1));
    $("next-frame").addEventListener("click", () => stepFrame(1));
    $("prev-event").addEventListener("click", () => (pause(), prevEvent()));
    $("next-event").addEventListener("click", () => (pause(), nextEvent()));
    window.addEventListener("keydown", (e) => {
      if (e.target instanceof HTMLSelectElement || e.target instanceof HTMLInputElement) {
        if (e.target.type !== "range") return;
      }
      if (e.key === " " && e.target instanceof HTMLButtonElement) return; // the button's own click
      if (e.key === " ") (playing ? pause() : play(), e.preventDefault());
      else if (e.key === "ArrowLeft") (stepFrame(-1), e.preventDefault());
      else if (e.key === "ArrowRight") (stepFrame(1), e.preventDefault());
      else if (e.key === "[") (pause(), prevEvent());
      else if (e.key === "]") (pause(), nextEvent());
    });

    $("title").textContent = data.meta.scenario || data.meta.file || "run";
    const collapse = data.meta.collapse;
    $("facts").textContent = [
      data.meta.file,
      [data.meta.backend, data.meta.mode, data.meta.model].filter(Boolean).join(" "),
      collapse ? `collapse at level ${collapse.level} (${collapse.brick}, level ${collapse.brick_level}) at ${fmt(collapse.time, 3)} s` : "stands",
      `${n} bodies, ${times.length} frames`,
      `three.js ${THREE.REVISION}`,
    ]
      .filter(Boolean)
      .join(" · ");
    const seen = new Set();
    for (let r = 0; r < rowState.length; r++) seen.add(data.levels[rowBody[r]] === 0 ? "projectile" : data.states[rowState[r]]);
    if (data.fixtures.length) seen.add("fixture");
    $("legend").innerHTML = ["active", "frozen", "woken", "fallen", "projectile", "fixture"]
      .filter((k) => seen.has(k))
      .map((k) => `<span class="key"><span class="swatch" style="background:${data.colours[k]}"></span>${k === "projectile" ? "thrown or pushing" : k}</span>`)
      .join("");

    if (data.golden_note) {
      $("ghost-box").hidden = false;
      $("ghost-text").textContent = data.golden_note;
      $("ghost-mode").parentElement.hidden = true;
    }
    if (data.golden_bricks !== null && !data.ghosts.length) {
      $("ghost-box").hidden = false;
      $("ghost-text").textContent = `All ${data.golden_bricks} bricks of the golden snapshot end where this run's do (within 1 mm and 1 deg, in the same state).`;
      $("ghost-mode").parentElement.hidden = true;
    }
    if (data.ghosts.length) {
      $("ghost-box").hidden = false;
      $("ghost-text").textContent = `${data.ghosts.length} brick(s) end elsewhere in the golden snapshot, drawn green:`;
      $("ghost-list").innerHTML = data.ghosts.map((g) => `<li>${escapeHtml(g.id)}: ${escapeHtml(g.why)}</li>`).join("");
      $("ghost-mode").addEventListener("change", () => {
        const mode = $("ghost-mode").value;
        ghostGroup.visible = mode !== "off";
        ghostGroup.position.set(mode === "beside" ? 1.3 * Math.max(size.x, size.y, 0.1) : 0, 0, 0);
        draw();
      });
    }

    $("message").remove();
    new ResizeObserver(resize).observe(view);
    resize();
    apply(0);
    // the moment the expectations judge: the collapse, or the end (a toppled row, or nothing collapsed)
    if (collapse && data.opening !== "end") seekEvent(collapse.time);
    else seek(data.end);
    if (collapse && index.has(collapse.brick)) select(collapse.brick); // the brick that moved first

    Object.assign(api, {
      seek: (t) => (seek(t), frame),
      seekEvent: (t) => (seekEvent(t), frame),
      time: () => now,
      frame: () => frame,
      frameTime: () => times[frame],
      end: data.end,
      ids: ids.slice(),
      events: events.slice(),
      poses() {
        const out = {};
        for (let b = 0; b < n; b++) {
          const r = rowOf[b];
          out[ids[b]] =
            r < 0
              ? null
              : {
                  position: [rowPos[3 * r], rowPos[3 * r + 1], rowPos[3 * r + 2]],
                  quaternion: [rowQuat[4 * r], rowQuat[4 * r + 1], rowQuat[4 * r + 2], rowQuat[4 * r + 3]],
                  state: data.states[stateOf[b]],
                };
        }
        return out;
      },
      fixtures() {
        // each fixture's position in the world now: at rest, carried by the ground's offset
        const out = {};
        table.updateMatrixWorld(true);
        data.fixtures.forEach((f, i) => (out[f.id] = fixtureMeshes[i].getWorldPosition(new THREE.Vector3()).toArray()));
        return out;
      },
      groundOffset: () => Array.from(groundOffset.subarray(3 * frame, 3 * frame + 3)),
      select,
      selected: () => selected,
      panelText: () => ($("panel").hidden ? null : $("panel").innerText),
      pick,
      screenPosition,
      nextEvent,
      prevEvent,
      play,
      pause,
      playing: () => playing,
      rate: factor,
      advance,
      ghosts: () => data.ghosts.map((g) => g.id),
      camera: () => ({ position: camera.position.toArray(), target: controls.target.toArray() }),
      render: () => renderer.render(scene, camera),
    });
    renderer.render(scene, camera);
    api.loadMs = performance.now();
    api.ready = true;
  }

  start().catch((e) => {
    api.error = String((e && e.stack) || e);
    const m = document.getElementById("message");
    if (m) m.textContent = `the replay could not start: ${e}`;
    console.error(e);
  });
})();
