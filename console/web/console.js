// SPDX-License-Identifier: BSD-3-Clause
// The operations console's page (issue 11): the roadway model in 3-D (three.js r111 from
// Debian's libjs-three, served by adit itself), a top view and a side profile on 2-D canvases,
// the robots' state from the /ws/view stream, operator commands through POST /api/commands,
// and a replay over the stored history. Protocol: console/doc/protocol.md.
//
// The control room's part: e-stops (per robot and for all, shown until released), the centre's
// alarms with their acknowledgement, the selected robot's speed and clearance as time-series,
// a scale bar and north arrow in both views, layer toggles, and a 3-D view that follows the
// selected robot.
//
// For tests the <html> element carries data-ready, data-errors, data-robots, data-webgl,
// data-estops (the robots whose e-stop is in force, "robot:status,..."), data-alarms (open
// alarms), data-series (the selected robot's samples with a clearance), data-layers (those shown)
// and data-scale (the top view's scale bar, "metres,pixels"); every robot row carries its pose (data-pose) and where its
// marker is drawn (data-drawn: the marker's 3-D position; data-top: its pixel in the top view).
'use strict';
(function () {
  const root = document.documentElement;
  const $ = (id) => document.getElementById(id);
  let errors = 0;
  function fail(message) {
    errors += 1;
    root.dataset.errors = String(errors);
    $('errors').textContent += message + '\n';
  }
  window.addEventListener('error', (e) => fail(e.message));
  window.addEventListener('unhandledrejection', (e) => fail(String(e.reason)));

  const COLOURS = ['#4fc3f7', '#ffb74d', '#ba68c8', '#81c784', '#f06292', '#fff176', '#90a4ae', '#e57373'];
  const TRAIL_MAX = 3000;
  const SERIES_SECONDS = 60;  // of mission time, the time-series' window
  const SERIES_MAX = 3000;
  const FOLLOW_DISTANCE = 30;  // [m] from a robot newly followed in 3-D
  const state = {
    map: null,
    robots: new Map(),  // id -> {telemetry, plan, tracks, rock: [], trail: [], colour, radius, view: {...}}
    commands: new Map(),
    events: [],
    replay: null,       // {robot, messages} when not live
    goalMode: false,
    alarms: new Map(),  // alarm_id -> the centre's alarm, while open
    layers: {},         // layer name -> shown
  };
  for (const box of document.querySelectorAll('#layers input[data-layer]')) {
    state.layers[box.dataset.layer] = box.checked;
    box.addEventListener('change', () => {
      state.layers[box.dataset.layer] = box.checked;
      for (const r of state.robots.values()) r.dirty = true;
      applyLayers();
    });
  }
  const shownLayer = (name) => state.layers[name] !== false;

  // ----- 3-D view --------------------------------------------------------------------------
  const three = { renderer: null, scene: null, camera: null, controls: null, mesh: null, labels: [] };

  function setUp3d(map, meshData) {
    const host = $('view3d');
    let renderer;
    try {
      renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    } catch (e) {
      $('nowebgl').hidden = false;
      return;
    }
    root.dataset.webgl = '1';
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    host.appendChild(renderer.domElement);
    const scene = new THREE.Scene();
    scene.background = new THREE.Color(0x15181c);
    const lo = map.bounds.min, hi = map.bounds.max;
    const centre = new THREE.Vector3((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2);
    const span = Math.max(hi[0] - lo[0], hi[1] - lo[1], 10);
    const camera = new THREE.PerspectiveCamera(45, 1, 0.1, span * 20);
    camera.up.set(0, 0, 1);  // the map's frame: z up
    // Far enough to see the whole map: its half diagonal fills the field of view.
    const half = 0.5 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
    const dist = half / Math.sin((camera.fov / 2) * Math.PI / 180);
    camera.position.set(centre.x, centre.y - 0.55 * dist, centre.z + 0.83 * dist);
    const controls = new THREE.OrbitControls(camera, renderer.domElement);
    controls.target.copy(centre);
    controls.update();
    scene.add(new THREE.HemisphereLight(0xdde6ff, 0x202020, 0.8));
    const sun = new THREE.DirectionalLight(0xffffff, 0.6);
    sun.position.set(0.3, -0.5, 1);
    scene.add(sun);
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(meshData.positions, 3));
    g.setAttribute('normal', new THREE.Float32BufferAttribute(meshData.normals, 3));
    g.setIndex(meshData.indices);
    // See-through rock surface: robots inside the roadways stay visible from outside.
    const mesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({
      color: 0x8d8672, side: THREE.DoubleSide, transparent: true, opacity: 0.35, depthWrite: false }));
    scene.add(mesh);
    const centrelines = new THREE.Group();
    scene.add(centrelines);
    for (const r of map.roadways) {
      const pts = r.centreline.map((p) => new THREE.Vector3(p[0], p[1], p[2]));
      centrelines.add(new THREE.Line(new THREE.BufferGeometry().setFromPoints(pts),
        new THREE.LineBasicMaterial({ color: 0x51606f })));
      const mid = r.centreline[Math.floor(r.centreline.length / 2)];
      const a = r.centreline[Math.floor((r.centreline.length - 1) / 2)];
      addLabel(r.name, 'roadway', [(a[0] + mid[0]) / 2, (a[1] + mid[1]) / 2, (a[2] + mid[2]) / 2 + 3]);
    }
    Object.assign(three, { renderer, scene, camera, controls, mesh, centrelines });
    applyLayers();
    renderer.domElement.addEventListener('click', onClick3d);
    window.addEventListener('resize', resize3d);
    resize3d();
  }

  function resize3d() {
    if (!three.renderer) return;
    const host = $('view3d');
    const w = host.clientWidth || 800, h = host.clientHeight || 600;
    three.renderer.setSize(w, h);
    three.camera.aspect = w / h;
    three.camera.updateProjectionMatrix();
  }

  function addLabel(text, kind, position) {
    const el = document.createElement('span');
    el.textContent = text;
    el.className = kind;
    $('labels').appendChild(el);
    const label = { el, position: new THREE.Vector3(position[0], position[1], position[2]), kind };
    three.labels.push(label);
    return label;
  }

  function applyLayers() {
    root.dataset.layers = Object.keys(state.layers).filter(shownLayer).join(',');
    if (!three.scene) return;
    three.mesh.visible = shownLayer('rock');
    three.centrelines.visible = shownLayer('rock');
  }

  // The label kinds each layer holds: roadway names with the names, break points with the paths.
  function labelShown(l) {
    if (l.kind === 'roadway' || l.kind === 'robot') return shownLayer('labels');
    if (l.kind === 'break') return shownLayer('plan');
    return true;
  }

  function placeLabels() {
    if (!three.renderer) return;
    const w = three.renderer.domElement.clientWidth, h = three.renderer.domElement.clientHeight;
    for (const l of three.labels) {
      const p = l.position.clone().project(three.camera);
      const visible = p.z < 1 && Math.abs(p.x) <= 1 && Math.abs(p.y) <= 1 && !l.el.hidden && labelShown(l);
      l.el.style.display = visible ? '' : 'none';
      l.el.style.left = ((p.x + 1) / 2 * w).toFixed(0) + 'px';
      l.el.style.top = ((1 - p.y) / 2 * h).toFixed(0) + 'px';
    }
  }

  function robotView(r) {
    if (r.view || !three.scene) return r.view;
    const colour = new THREE.Color(r.colour);
    const material = new THREE.MeshLambertMaterial({ color: colour });
    const marker = new THREE.Mesh(new THREE.SphereBufferGeometry(1, 20, 14), material);
    // A ground robot that reports its body (telemetry 'body', 'yaw') is drawn as that box.
    const box = new THREE.Mesh(new THREE.BoxBufferGeometry(1, 1, 1), material);
    box.visible = false;
    // A round one (telemetry 'body_shape': 'cylinder') as its cylinder, stood on its end.
    const cylinder = new THREE.Mesh(new THREE.CylinderBufferGeometry(0.5, 0.5, 1, 24), material);
    cylinder.rotation.set(Math.PI / 2, 0, 0);
    cylinder.visible = false;
    const trail = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineBasicMaterial({ color: colour }));
    const plan = new THREE.Line(new THREE.BufferGeometry(), new THREE.LineDashedMaterial({ color: 0xffd866, dashSize: 1, gapSize: 0.6 }));
    const subgoal = new THREE.Mesh(new THREE.OctahedronBufferGeometry(0.5), new THREE.MeshBasicMaterial({ color: 0xffd866 }));
    const rock = new THREE.Points(new THREE.BufferGeometry(), new THREE.PointsMaterial({ color: 0xff7043, size: 0.25 }));
    const tracks = new THREE.Group();
    subgoal.visible = false;
    for (const o of [marker, box, cylinder, trail, plan, subgoal, rock, tracks]) three.scene.add(o);
    r.view = { marker, box, cylinder, trail, plan, subgoal, rock, tracks, breakLabels: [], name: addLabel(r.id, 'robot', [0, 0, 0]) };
    return r.view;
  }

  // A robot is its radius when close, and never smaller than ~1 % of the view when far.
  function markerScale(r, position) {
    return Math.max(r.radius, 0.012 * three.camera.position.distanceTo(position));
  }

  function points3(list) { return list.map((p) => new THREE.Vector3(p[0], p[1], p[2])); }

  // ----- robots' state -------------------------------------------------------------------------
  function robot(id) {
    let r = state.robots.get(id);
    if (!r) {
      r = { id, telemetry: null, plan: null, tracks: [], rock: [], trail: [], trailSeq: [], radius: 0.4,
            colour: COLOURS[state.robots.size % COLOURS.length], view: null, dirty: true,
            series: [], estop: null };
      state.robots.set(id, r);
      const option = document.createElement('option');
      option.value = option.textContent = id;
      $('robot').appendChild(option);
      root.dataset.robots = String(state.robots.size);
    }
    return r;
  }

  function apply(m) {
    if (m.type === 'telemetry') {
      const r = robot(m.robot);
      r.telemetry = m;
      addSample(r, m);
      r.trail.push(m.pose);
      r.trailSeq.push(m.seq);
      if (r.trail.length > TRAIL_MAX) {
        r.trail.splice(0, r.trail.length - TRAIL_MAX);
        r.trailSeq.splice(0, r.trailSeq.length - TRAIL_MAX);
      }
      r.dirty = true;
    } else if (m.type === 'plan') {
      robot(m.robot).plan = m;
      robot(m.robot).dirty = true;
    } else if (m.type === 'obstacles') {
      const r = robot(m.robot);
      r.tracks = m.tracks || [];
      for (const p of m.rock || []) r.rock.push(p);
      if (r.rock.length > 50000) r.rock.splice(0, r.rock.length - 50000);
      r.dirty = true;
    } else if (m.type === 'event') {
      state.events.push(m);
      addItem('events', `${m.robot} t=${Number(m.t).toFixed(1)} s: ${m.kind}` +
        (m.center ? ` at (${m.center.map((v) => v.toFixed(1)).join(', ')})` : ''));
    } else if (m.type === 'command') {
      state.commands.set(m.command_id, m);
      renderCommands();
    } else if (m.type === 'estop') {
      robot(m.robot).estop = m.estop;
      renderEstops();
    } else if (m.type === 'alarm') {
      if (m.open) state.alarms.set(m.alarm_id, m);
      else state.alarms.delete(m.alarm_id);
      renderAlarms();
    } else if (m.type === 'lag') {
      addItem('events', `the view fell behind: ${m.dropped} telemetry messages skipped`);
    }
  }

  // One sample per telemetry: its mission time, speed (the robot's, else |velocity|) and
  // clearance (null when the robot did not know it). A new run's clock starting again ends the
  // old series.
  function addSample(r, m) {
    const last = r.series[r.series.length - 1];
    if (last && m.t < last.t) r.series = [];
    const speed = m.speed != null ? m.speed : Math.hypot(...m.velocity);
    r.series.push({ seq: m.seq, t: m.t, speed, clearance: m.min_clearance != null ? m.min_clearance : null });
    if (r.series.length > SERIES_MAX) r.series.splice(0, r.series.length - SERIES_MAX);
  }

  function addItem(list, text) {
    const li = document.createElement('li');
    li.textContent = text;
    const ul = $(list);
    ul.appendChild(li);
    while (ul.children.length > 200) ul.removeChild(ul.firstChild);
    ul.scrollTop = ul.scrollHeight;
  }

  function renderCommands() {
    const ul = $('commands');
    ul.textContent = '';
    const list = [...state.commands.values()].sort((a, b) => a.command_id - b.command_id).slice(-50);
    for (const c of list) {
      const li = document.createElement('li');
      const arg = c.goal ? ' (' + c.goal.map((v) => v.toFixed(1)).join(', ') + ')' : c.roadway ? ' ' + c.roadway : '';
      li.textContent = `#${c.command_id} ${c.robot} ${c.kind}${arg} by ${c.operator}: ${c.status}${c.reason ? ' - ' + c.reason : ''}`;
      ul.appendChild(li);
    }
  }

  function renderEstops() {
    const bar = $('estops');
    bar.textContent = '';
    const held = [...state.robots.values()].filter((r) => r.estop);
    for (const r of held) {
      const e = r.estop;
      const div = document.createElement('div');
      div.dataset.robot = r.id;
      div.textContent = `E-STOP ${r.id}: ` + (e.engaged ? 'engaged, acknowledged by the robot' :
        e.status === 'refused' ? `REFUSED by the robot (${e.reason})` : `${e.status}, waiting for the robot`) +
        ` (command #${e.command_id} by ${e.operator} at ${e.issued_at.slice(11, 19)} UTC); until released`;
      bar.appendChild(div);
    }
    bar.hidden = held.length === 0;
    root.dataset.estops = held.map((r) => `${r.id}:${r.estop.engaged ? 'engaged' : r.estop.status}`).join(',');
  }

  function renderAlarms() {
    const ul = $('alarms');
    ul.textContent = '';
    const rank = { critical: 0, major: 1, minor: 2 };
    const list = [...state.alarms.values()].sort((a, b) =>
      (!!a.acked_at - !!b.acked_at) || (rank[a.severity] - rank[b.severity]) || (b.alarm_id - a.alarm_id));
    for (const a of list) {
      const li = document.createElement('li');
      li.className = a.severity + (a.acked_at ? ' acked' : '');
      li.dataset.alarmId = a.alarm_id;
      li.dataset.kind = a.kind;
      li.textContent = `${a.severity.toUpperCase()} ${a.robot} ${a.kind.replace('_', ' ')}: ${a.message}` +
        ` (${a.raised_at.slice(11, 19)}${a.cleared_at ? ', cleared ' + a.cleared_at.slice(11, 19) : ', active'})`;
      if (a.acked_at) {
        li.textContent += ` - acknowledged by ${a.acked_by} at ${a.acked_at.slice(11, 19)}`;
      } else {
        const b = document.createElement('button');
        b.textContent = 'Ack';
        b.className = 'ack';
        b.onclick = () => acknowledge(a.alarm_id);
        li.appendChild(document.createTextNode(' '));
        li.appendChild(b);
      }
      ul.appendChild(li);
    }
    root.dataset.alarms = String(list.length);
    root.dataset.unacked = String(list.filter((a) => !a.acked_at).length);
  }

  async function acknowledge(id) {
    const res = await authed('/api/alarms/ack', {
      method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ alarm_id: id }) });
    const answer = await res.json();
    if (res.ok) { state.alarms.set(id, answer); if (!answer.open) state.alarms.delete(id); renderAlarms(); }
    $('answer').textContent = res.ok ? `alarm #${id} acknowledged` : `refused (${res.status}): ${answer.error}`;
    $('answer').className = res.ok ? 'ok' : 'bad';
    root.dataset.lastAck = res.ok ? String(id) : 'refused ' + res.status;
  }

  // The telemetry shown for a robot: the live one, or the replay's at the slider.
  function shown(r) {
    if (state.replay && state.replay.robot === r.id) return state.replay.current;
    return r.telemetry;
  }

  function update3d(r) {
    const v = robotView(r);
    const t = shown(r);
    if (!v || !t) return;
    v.marker.position.set(t.pose[0], t.pose[1], t.pose[2]);
    v.marker.scale.setScalar(markerScale(r, v.marker.position));
    const body = Array.isArray(t.body) && t.body.length === 3 ? t.body : null;
    const round = !!body && t.body_shape === 'cylinder';
    v.marker.visible = !body;
    v.box.visible = !!body && !round;
    v.cylinder.visible = round;
    if (body) {
      // Its own size when close; grown like the sphere when far, so that it stays in sight.
      const grow = Math.max(1, markerScale(r, v.marker.position) / Math.max(0.5 * Math.hypot(body[0], body[1]), 1e-3));
      if (round) {
        // The cylinder's axis is its local y, stood up along z: [diameter, height, diameter].
        v.cylinder.position.copy(v.marker.position);
        v.cylinder.scale.set(body[0] * grow, body[2] * grow, body[1] * grow);
      } else {
        v.box.position.copy(v.marker.position);
        v.box.scale.set(body[0] * grow, body[1] * grow, body[2] * grow);
        v.box.rotation.set(0, 0, typeof t.yaw === 'number' ? t.yaw : 0);
      }
    }
    v.name.position.set(t.pose[0], t.pose[1], t.pose[2] + r.radius + 0.5);
    const trail = state.replay && state.replay.robot === r.id ? state.replay.trail : r.trail;
    v.trail.geometry.setFromPoints(points3(trail));
    v.trail.visible = shownLayer('trail');
    v.plan.visible = shownLayer('plan');
    v.rock.visible = shownLayer('sensed');
    v.tracks.visible = shownLayer('tracks');
    if (r.plan && r.plan.path.length > 1) {
      v.plan.geometry.setFromPoints(points3(r.plan.path));
      v.plan.computeLineDistances();
      const labels = r.plan.labels || [];
      while (v.breakLabels.length < labels.length) v.breakLabels.push(addLabel('', 'break', [0, 0, 0]));
      v.breakLabels.forEach((l, i) => {
        const p = r.plan.path[i + 1];
        l.el.hidden = i >= labels.length || !p;
        if (!l.el.hidden) {
          l.el.textContent = labels[i];
          l.position.set(p[0], p[1], p[2] + 1);
        }
      });
    }
    v.subgoal.visible = !!t.subgoal;
    if (t.subgoal) v.subgoal.position.set(t.subgoal[0], t.subgoal[1], t.subgoal[2]);
    v.rock.geometry.setFromPoints(points3(r.rock));
    while (v.tracks.children.length) v.tracks.remove(v.tracks.children[0]);
    for (const tr of r.tracks) {
      const s = new THREE.Mesh(new THREE.SphereBufferGeometry(tr.radius || 1, 12, 8),
        new THREE.MeshLambertMaterial({ color: 0xef5350, transparent: true, opacity: 0.7 }));
      s.position.set(tr.position[0], tr.position[1], tr.position[2]);
      v.tracks.add(s);
    }
  }

  function renderTable() {
    const body = $('robots').tBodies[0];
    for (const r of state.robots.values()) {
      let row = body.querySelector(`tr[data-robot="${CSS.escape(r.id)}"]`);
      if (!row) {
        row = body.insertRow();
        row.dataset.robot = r.id;
        for (let i = 0; i < 7; ++i) row.insertCell();
        row.cells[0].style.color = r.colour;
        row.cells[0].textContent = r.id;
        const stop = document.createElement('button');
        stop.className = 'estop';
        stop.textContent = 'STOP';
        stop.title = 'E-stop ' + r.id;
        stop.onclick = () => command({ kind: 'estop' }, r.id);
        row.cells[6].appendChild(stop);
      }
      const t = shown(r);
      if (!t) continue;
      row.cells[1].textContent = t.status;
      row.cells[2].textContent = t.pose.map((v) => v.toFixed(1)).join(' ');
      row.cells[3].textContent = t.min_clearance != null ? Number(t.min_clearance).toFixed(2) + ' m' : '';
      const speed = t.speed != null ? t.speed : Math.hypot(...t.velocity);
      row.cells[4].textContent = speed.toFixed(2) + ' m/s';
      row.cells[5].textContent = t.seq;
      row.className = r.estop ? 'estop' : '';
      row.dataset.pose = t.pose.join(',');
      row.dataset.status = t.status;
      if (r.view) {
        const p = r.view.marker.position;
        row.dataset.drawn = [p.x, p.y, p.z].join(',');
      }
      const px = topPixel(t.pose);
      if (px) row.dataset.top = px.map((v) => v.toFixed(1)).join(',');
    }
  }

  // ----- top view and side profile -------------------------------------------------------------
  let topScale = null;
  function topPixel(p) {
    if (!topScale) return null;
    return [topScale.ox + (p[0] - topScale.x0) * topScale.s, topScale.oy - (p[1] - topScale.y0) * topScale.s];
  }
  function topPoint(px, py) {
    return [(px - topScale.ox) / topScale.s + topScale.x0, (topScale.oy - py) / topScale.s + topScale.y0];
  }

  function drawTop() {
    const c = $('top'), g = c.getContext('2d');
    const lo = state.map.bounds.min, hi = state.map.bounds.max;
    const s = Math.min((c.width - 20) / Math.max(hi[0] - lo[0], 1), (c.height - 20) / Math.max(hi[1] - lo[1], 1));
    topScale = { s, x0: lo[0], y0: lo[1], ox: 10, oy: c.height - 10 };
    g.clearRect(0, 0, c.width, c.height);
    g.lineCap = 'round';
    g.lineJoin = 'round';
    if (shownLayer('rock'))
      for (const r of state.map.roadways) {
        g.strokeStyle = '#3a4450';
        g.lineWidth = Math.max(2, r.width * s);
        polyline(g, r.centreline.map(topPixel));
      }
    g.fillStyle = '#9fb3c8';
    g.font = '10px sans-serif';
    if (shownLayer('labels'))
      for (const r of state.map.roadways) {
        const p = topPixel(r.centreline[Math.floor(r.centreline.length / 2)]);
        g.fillText(r.name, p[0] + 3, p[1] - 3);
      }
    for (const r of state.robots.values()) {
      const t = shown(r);
      if (r.plan && shownLayer('plan')) {
        g.strokeStyle = '#ffd866';
        g.lineWidth = 1;
        g.setLineDash([4, 3]);
        polyline(g, r.plan.path.map(topPixel));
        g.setLineDash([]);
        g.fillStyle = '#ffd866';
        (r.plan.labels || []).forEach((l, i) => {
          const p = r.plan.path[i + 1];
          if (p) { const q = topPixel(p); g.fillText(l, q[0] + 3, q[1] + 10); }
        });
      }
      g.strokeStyle = r.colour;
      g.lineWidth = 1.5;
      if (shownLayer('trail'))
        polyline(g, (state.replay && state.replay.robot === r.id ? state.replay.trail : r.trail).map(topPixel));
      g.fillStyle = '#ff7043';
      if (shownLayer('sensed')) for (const p of r.rock) { const q = topPixel(p); g.fillRect(q[0] - 1, q[1] - 1, 2, 2); }
      g.fillStyle = '#ef5350';
      if (shownLayer('tracks')) for (const tr of r.tracks) dot(g, topPixel(tr.position), Math.max(3, (tr.radius || 1) * s));
      if (t) {
        g.fillStyle = r.colour;
        if (Array.isArray(t.body) && t.body.length === 3)
          (t.body_shape === 'cylinder' ? roundTop : boxTop)(g, topPixel(t.pose), t.body, t.yaw || 0, s);
        else dot(g, topPixel(t.pose), Math.max(4, r.radius * s));
        if (r.estop) {  // an e-stopped robot is ringed in red in every view
          g.strokeStyle = '#ff1744';
          g.lineWidth = 2;
          g.beginPath();
          g.arc(topPixel(t.pose)[0], topPixel(t.pose)[1], Math.max(8, r.radius * s + 4), 0, 2 * Math.PI);
          g.stroke();
        }
        if (t.subgoal) { g.fillStyle = '#ffd866'; dot(g, topPixel(t.subgoal), 3); }
      }
    }
    g.strokeStyle = '#ff7b72';
    g.lineWidth = 1;
    for (const e of shownLayer('events') ? state.events : []) {
      if (!e.center) continue;
      const p = topPixel(e.center);
      g.beginPath();
      g.arc(p[0], p[1], Math.max(4, (e.radius || 1) * s), 0, 2 * Math.PI);
      g.stroke();
    }
    // Top left: the mine's roadways run along the bottom edge of most plans.
    const bar = scaleBar(g, s, 10, 16);
    root.dataset.scale = `${bar.metres},${bar.pixels.toFixed(1)}`;
    northArrow(g, c.width - 18, 26, 0, -1);
  }

  // The longest 1, 2 or 5 x 10^k metres that fits in `maxPx` pixels at `pxPerM`.
  function niceLength(pxPerM, maxPx) {
    let best = 1;
    for (let k = -2; k <= 5; ++k)
      for (const m of [1, 2, 5]) {
        const v = m * Math.pow(10, k);
        if (v * pxPerM <= maxPx) best = v;
      }
    return best;
  }

  function scaleBar(g, pxPerM, x, y) {
    const metres = niceLength(pxPerM, 110);
    const pixels = metres * pxPerM;
    g.strokeStyle = g.fillStyle = '#dde3ea';
    g.lineWidth = 2;
    g.beginPath();
    g.moveTo(x, y - 4); g.lineTo(x, y); g.lineTo(x + pixels, y); g.lineTo(x + pixels, y - 4);
    g.stroke();
    g.font = '10px sans-serif';
    g.fillText(metres >= 1 ? `${metres} m` : `${metres * 100} cm`, x + pixels + 4, y);
    return { metres, pixels };
  }

  // North is the map frame's +y (grid north of the survey): an arrow toward (dx, dy) on screen.
  function northArrow(g, x, y, dx, dy) {
    const n = Math.hypot(dx, dy) || 1;
    dx /= n; dy /= n;
    const len = 14;
    g.strokeStyle = g.fillStyle = '#dde3ea';
    g.lineWidth = 2;
    g.beginPath();
    g.moveTo(x - dx * len, y - dy * len);
    g.lineTo(x + dx * len, y + dy * len);
    g.stroke();
    g.beginPath();
    g.moveTo(x + dx * (len + 4), y + dy * (len + 4));
    g.lineTo(x + dx * (len - 4) - dy * 5, y + dy * (len - 4) + dx * 5);
    g.lineTo(x + dx * (len - 4) + dy * 5, y + dy * (len - 4) - dx * 5);
    g.fill();
    g.font = 'bold 11px sans-serif';
    g.fillText('N', x + dx * (len + 8) - 4, y + dy * (len + 8) + 4);
  }

  // The 3-D view's scale bar (metres at the distance of the orbit's centre) and its north arrow
  // (the map's +y as seen from the camera).
  function drawOverlay3d() {
    const c = $('overlay3d'), g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    const cam = three.camera, target = three.controls.target;
    const h = three.renderer.domElement.clientHeight || 600;
    const dist = cam.position.distanceTo(target);
    const pxPerM = h / (2 * dist * Math.tan((cam.fov / 2) * Math.PI / 180));
    const bar = scaleBar(g, pxPerM, 6, c.height - 8);
    root.dataset.scale3d = `${bar.metres},${bar.pixels.toFixed(1)}`;
    const a = target.clone().project(cam), b = target.clone().add(new THREE.Vector3(0, 1, 0)).project(cam);
    northArrow(g, c.width - 24, 30, b.x - a.x, -(b.y - a.y) * h / (three.renderer.domElement.clientWidth || 800));
  }

  // The selected robot's speed (blue) and clearance (green; the alarm margin dashed) over the last
  // SERIES_SECONDS of its mission time.
  function drawSeries() {
    const c = $('series'), g = c.getContext('2d');
    g.clearRect(0, 0, c.width, c.height);
    const r = state.robots.get($('robot').value);
    g.font = '10px sans-serif';
    g.fillStyle = '#9fb3c8';
    if (!r || !r.series.length) { g.fillText('speed and clearance: no telemetry yet', 6, 14); root.dataset.series = '0'; return; }
    // The window's left edge: SERIES_SECONDS back, or the first sample of a shorter run.
    const t1 = r.series[r.series.length - 1].t, t0 = Math.max(t1 - SERIES_SECONDS, r.series[0].t);
    const span = Math.max(t1 - t0, 1);
    const pts = r.series.filter((p) => p.t >= t0);
    const vmax = Math.max(0.5, ...pts.map((p) => p.speed));
    const cmax = Math.max(1, ...pts.filter((p) => p.clearance != null).map((p) => p.clearance));
    const L = 34, R = c.width - 34, T = 16, B = c.height - 14;
    const x = (t) => L + (t - t0) / span * (R - L);
    g.strokeStyle = '#333a42';
    g.strokeRect(L, T, R - L, B - T);
    const plot = (value, max, colour) => {
      g.strokeStyle = colour;
      g.lineWidth = 1.5;
      g.beginPath();
      let pen = false;
      for (const p of pts) {
        const v = value(p);
        if (v == null) { pen = false; continue; }
        const y = B - Math.min(v, max) / max * (B - T);
        if (pen) g.lineTo(x(p.t), y); else g.moveTo(x(p.t), y);
        pen = true;
      }
      g.stroke();
    };
    plot((p) => p.speed, vmax, '#4fc3f7');
    plot((p) => p.clearance, cmax, '#81c784');
    if (state.margin != null) {
      const y = B - state.margin / cmax * (B - T);
      g.strokeStyle = '#81c784';
      g.setLineDash([3, 3]);
      g.beginPath(); g.moveTo(L, y); g.lineTo(R, y); g.stroke();
      g.setLineDash([]);
    }
    const last = r.series[r.series.length - 1];
    g.fillStyle = '#4fc3f7';
    g.fillText(`speed ${last.speed.toFixed(2)} m/s (max ${vmax.toFixed(1)})`, L, 11);
    g.fillStyle = '#81c784';
    g.fillText(`clearance ${last.clearance != null ? last.clearance.toFixed(2) + ' m' : '-'} (max ${cmax.toFixed(1)})`, L + 200, 11);
    g.fillStyle = '#9fb3c8';
    g.fillText(`${r.id}: t = ${t0.toFixed(1)} to ${t1.toFixed(1)} s (at most the last ${SERIES_SECONDS} s)`, L, c.height - 2);
    root.dataset.series = String(pts.filter((p) => p.clearance != null).length);
  }

  function drawProfile() {
    const c = $('profile'), g = c.getContext('2d');
    const lo = state.map.bounds.min, hi = state.map.bounds.max;
    const sx = (c.width - 20) / Math.max(hi[0] - lo[0], 1), sz = (c.height - 20) / Math.max(hi[2] - lo[2], 1);
    const px = (p) => [10 + (p[0] - lo[0]) * sx, c.height - 10 - (p[2] - lo[2]) * sz];
    g.clearRect(0, 0, c.width, c.height);
    g.fillStyle = '#9fb3c8';
    g.font = '10px sans-serif';
    g.fillText(`profile: z over x, ${lo[2].toFixed(0)} to ${hi[2].toFixed(0)} m`, 4, 11);
    for (const r of state.map.roadways) {
      g.strokeStyle = '#3a4450';
      g.lineWidth = 2;
      polyline(g, r.centreline.map(px));
    }
    for (const r of state.robots.values()) {
      const t = shown(r);
      if (r.plan && shownLayer('plan')) { g.strokeStyle = '#ffd866'; g.lineWidth = 1; polyline(g, r.plan.path.map(px)); }
      g.strokeStyle = r.colour;
      if (shownLayer('trail')) polyline(g, r.trail.map(px));
      if (t) { g.fillStyle = r.colour; dot(g, px(t.pose), 4); }
    }
  }

  function polyline(g, pts) {
    if (pts.length < 2) return;
    g.beginPath();
    g.moveTo(pts[0][0], pts[0][1]);
    for (const p of pts.slice(1)) g.lineTo(p[0], p[1]);
    g.stroke();
  }
  function dot(g, p, r) { g.beginPath(); g.arc(p[0], p[1], r, 0, 2 * Math.PI); g.fill(); }
  // A ground robot's footprint seen from above, turned to its heading (north up: the canvas turns
  // the other way), never smaller than a dot; a line from its centre marks its front.
  function boxTop(g, p, body, yaw, s) {
    const k = Math.max(1, 8 / Math.max(body[1] * s, 1e-3));
    const l = body[0] * s * k, w = body[1] * s * k;
    g.save();
    g.translate(p[0], p[1]);
    g.rotate(-yaw);
    g.fillRect(-l / 2, -w / 2, l, w);
    g.strokeStyle = '#101010';
    g.lineWidth = 1.5;
    g.beginPath(); g.moveTo(0, 0); g.lineTo(l / 2, 0); g.stroke();
    g.restore();
  }

  // A round ground robot seen from above: its disc, never smaller than a dot, and its front.
  function roundTop(g, p, body, yaw, s) {
    const rad = Math.max(4, 0.5 * body[0] * s);
    dot(g, p, rad);
    g.save();
    g.strokeStyle = '#101010';
    g.lineWidth = 1.5;
    g.beginPath(); g.moveTo(p[0], p[1]); g.lineTo(p[0] + rad * Math.cos(yaw), p[1] - rad * Math.sin(yaw)); g.stroke();
    g.restore();
  }

  // ----- the frame loop ------------------------------------------------------------------------
  function frame() {
    for (const r of state.robots.values()) {
      if (r.dirty) { update3d(r); r.dirty = false; }
    }
    drawTop();
    drawProfile();
    drawSeries();
    renderTable();
    if (three.renderer) {
      const followed = $('follow').checked && state.robots.get($('robot').value);
      if (followed && followed.view && shown(followed)) {
        const p = followed.view.marker.position;
        // A robot newly followed is approached to FOLLOW_DISTANCE, seen from where the camera
        // looked: the whole-mine view makes it a dot. Then the camera moves with it.
        if (three.followed !== followed.id) {
          three.followed = followed.id;
          const away = three.camera.position.clone().sub(three.controls.target);
          three.camera.position.copy(p.clone().add(away.setLength(FOLLOW_DISTANCE)));
          three.controls.target.copy(p);
        }
        three.camera.position.add(p.clone().sub(three.controls.target));
        three.controls.target.copy(p);
      } else {
        three.followed = null;
      }
      for (const r of state.robots.values()) if (r.view) r.view.marker.material.emissive.set(r.estop ? 0x990000 : 0x000000);
      for (const r of state.robots.values())
        if (r.view) r.view.marker.scale.setScalar(markerScale(r, r.view.marker.position));
      three.controls.update();
      placeLabels();
      drawOverlay3d();
      three.renderer.render(three.scene, three.camera);
    }
    requestAnimationFrame(frame);
  }

  // ----- the live stream ---------------------------------------------------------------------
  let retry = 500;
  function connect() {
    // A browser's WebSocket cannot send headers: the token goes in the query (never logged).
    const ws = new WebSocket(`ws://${location.host}/ws/view?token=${encodeURIComponent(token.value.trim())}`);
    ws.onopen = () => { $('conn').textContent = 'live'; $('conn').className = 'ok'; retry = 500; };
    ws.onclose = () => {
      $('conn').textContent = 'reconnecting';
      $('conn').className = 'bad';
      setTimeout(connect, retry);
      retry = Math.min(retry * 2, 10000);
    };
    ws.onmessage = (e) => {
      const m = JSON.parse(e.data);
      if (m.type === 'snapshot') {
        for (const r of m.robots) {
          const x = robot(r.robot);
          if (r.radius) x.radius = r.radius;
          if (!x.backfilled) backfill(x, r.last_seq);
          if (r.telemetry) apply(r.telemetry);
          if (r.plan) apply(r.plan);
          x.tracks = r.tracks || [];
          x.estop = r.estop || null;
        }
        for (const c of m.commands) apply(c);
        state.alarms.clear();
        for (const a of m.alarms || []) state.alarms.set(a.alarm_id, a);
        renderEstops();
        renderAlarms();
      } else {
        apply(m);
      }
      if (m.type === 'snapshot') { clickFromHash(); actFromHash(); }
    };
  }

  // `#token=T&robot=R&goal-click=X,Y`: once a robot is known, clicks the top view at map point (X, Y)
  // in goal mode, as an operator would (how the browser test sets a goal by a click).
  let hashClicked = false;
  function clickFromHash() {
    const params = new URLSearchParams(location.hash.slice(1));
    if (params.has('robot') && state.robots.has(params.get('robot'))) $('robot').value = params.get('robot');
    const at = params.get('goal-click');
    if (!at || hashClicked || !$('robot').value) return;
    hashClicked = true;
    const [x, y] = at.split(',').map(Number);
    drawTop();
    const c = $('top'), rect = c.getBoundingClientRect(), px = topPixel([x, y, 0]);
    if (!state.goalMode) $('goalmode').click();
    c.dispatchEvent(new MouseEvent('click', {
      clientX: rect.left + px[0] * rect.width / c.width, clientY: rect.top + px[1] * rect.height / c.height, bubbles: true }));
  }

  // `#estop-click=1`, `#estop-release-click=1`, `#estop-all-click=1`, `#ack-click=all`,
// `#layers-off=labels,trail` (unticks those layers): once the
  // snapshot is in, presses that button as an operator would (the browser test's e-stop and
  // acknowledgement). Each at most once per page load.
  const acted = new Set();
  function actFromHash() {
    const params = new URLSearchParams(location.hash.slice(1));
    const press = (key, act) => { if (params.get(key) && !acted.has(key)) { acted.add(key); act(); } };
    press('estop-click', () => $('estop').click());
    press('estop-release-click', () => $('estoprelease').click());
    press('estop-all-click', () => $('estopall').click());
    press('ack-click', () => { for (const b of document.querySelectorAll('#alarms button.ack')) b.click(); });
    press('layers-off', () => {
      for (const name of params.get('layers-off').split(',')) {
        const box = document.querySelector(`#layers input[data-layer="${CSS.escape(name)}"]`);
        if (box && box.checked) box.click();
      }
    });
  }

  // A page opened mid-run (or after it) draws the robot's recent past from the database: the
  // trail, sensed rock and events of its last TRAIL_MAX stored messages.
  async function backfill(r, lastSeq) {
    r.backfilled = true;
    const from = Math.max(1, lastSeq - TRAIL_MAX + 1);
    const res = await authed(`/api/history?robot=${encodeURIComponent(r.id)}&from_seq=${from}&limit=${TRAIL_MAX}`);
    if (!res.ok) return;
    const past = await res.json();
    const trail = [], seqs = [], series = { series: [] };
    for (const m of past) {
      if (m.type === 'telemetry') { trail.push(m.pose); seqs.push(m.seq); addSample(series, m); }
      else if (m.type === 'obstacles') for (const p of m.rock || []) r.rock.push(p);
      else if (m.type === 'event') apply(m);
    }
    // Live telemetry that arrived meanwhile continues the trail.
    const newest = past.length ? past[past.length - 1].seq : 0;
    const keep = r.trailSeq.map((seq) => seq > newest);
    r.trail = trail.concat(r.trail.filter((_, i) => keep[i]));
    r.trailSeq = seqs.concat(r.trailSeq.filter((_, i) => keep[i]));
    r.series = series.series.concat(r.series.filter((p) => p.seq > newest));
    r.dirty = true;
  }

  // ----- operator commands -------------------------------------------------------------------
  // Everything but the page itself needs the operator token (reading the mine included): from
  // `#token=T`, this tab's earlier entry, or the field.
  const token = $('token');
  const hashToken = new URLSearchParams(location.hash.slice(1)).get('token');
  token.value = hashToken || sessionStorage.getItem('adit-token') || '';
  if (hashToken) sessionStorage.setItem('adit-token', hashToken);
  token.addEventListener('change', () => sessionStorage.setItem('adit-token', token.value.trim()));
  function authed(url, options = {}) {
    return fetch(url, { ...options, headers: { ...(options.headers || {}), Authorization: 'Bearer ' + token.value.trim() } });
  }

  async function command(body, robotId) {
    body.robot = robotId || $('robot').value;
    if (!body.robot) { $('answer').textContent = 'no robot connected yet'; return; }
    const res = await authed('/api/commands', {
      method: 'POST',
      headers: { 'Content-Type': 'application/json' },
      body: JSON.stringify(body),
    });
    const answer = await res.json();
    $('answer').textContent = res.ok ? `command #${answer.command_id} ${body.kind}: ${answer.status}`
                                     : `refused (${res.status}): ${answer.error}`;
    root.dataset.lastCommand = res.ok ? String(answer.command_id) : 'refused ' + res.status;
    $('answer').className = res.ok ? 'ok' : 'bad';
  }

  $('estop').onclick = () => command({ kind: 'estop' });
  $('estoprelease').onclick = () => command({ kind: 'estop_release' });
  $('estopall').onclick = async () => {
    const res = await authed('/api/estop-all', { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: '{}' });
    const answer = await res.json();
    $('answer').textContent = res.ok ? `e-stop sent to ${answer.commands.length} robots` : `refused (${res.status}): ${answer.error}`;
    $('answer').className = res.ok ? 'ok' : 'bad';
    root.dataset.lastCommand = res.ok ? answer.commands.map((c) => c.command_id).join(',') : 'refused ' + res.status;
  };
  $('pause').onclick = () => command({ kind: 'pause' });
  $('resume').onclick = () => command({ kind: 'resume' });
  $('release').onclick = () => command({ kind: 'release' });
  $('block').onclick = () => command({ kind: 'block', roadway: $('roadway').value });
  $('reopen').onclick = () => command({ kind: 'reopen', roadway: $('roadway').value });
  $('goalmode').onclick = () => {
    state.goalMode = !state.goalMode;
    $('goalmode').setAttribute('aria-pressed', String(state.goalMode));
  };
  function manual(dx, dy) {
    const v = Number($('speed').value) || 0.5;
    command({ kind: 'manual', velocity: [dx * v, dy * v, 0] });
  }
  for (const b of document.querySelectorAll('.manual button[data-v]')) {
    const [dx, dy] = b.dataset.v.split(',').map(Number);
    b.onclick = () => manual(dx, dy);
  }
  const KEYS = { ArrowUp: [0, 1], ArrowDown: [0, -1], ArrowLeft: [-1, 0], ArrowRight: [1, 0], ' ': [0, 0] };
  window.addEventListener('keydown', (e) => {
    if (e.target.tagName === 'INPUT' || e.target.tagName === 'SELECT' || !KEYS[e.key]) return;
    e.preventDefault();
    manual(...KEYS[e.key]);
  });

  // A click on the model: the surface point, moved off the surface along its normal by the
  // robot's radius and a margin, so that a floor click is a goal at the robot's height.
  function goalOffSurface(point, normal) {
    const r = state.robots.get($('robot').value);
    const lift = (r ? r.radius : 0.4) + 0.6;
    return [point.x + normal.x * lift, point.y + normal.y * lift, point.z + normal.z * lift];
  }

  function onClick3d(e) {
    if (!state.goalMode) return;
    const rect = three.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((e.clientX - rect.left) / rect.width) * 2 - 1, -((e.clientY - rect.top) / rect.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, three.camera);
    // The first face hit that faces the camera... or the nearest one (DoubleSide).
    const hit = ray.intersectObject(three.mesh)[0];
    if (!hit) { $('answer').textContent = 'no roadway under the pointer'; return; }
    sendGoal(goalOffSurface(hit.point, hit.face.normal));
  }

  // The top view has no height: the nearest roadway centreline point gives it (the floor),
  // plus the robot's radius and a margin.
  $('top').addEventListener('click', (e) => {
    if (!state.goalMode || !topScale) return;
    const rect = e.target.getBoundingClientRect();
    const [x, y] = topPoint((e.clientX - rect.left) * e.target.width / rect.width, (e.clientY - rect.top) * e.target.height / rect.height);
    let best = null;
    for (const r of state.map.roadways) {
      for (let i = 0; i + 1 < r.centreline.length; ++i) {
        const a = r.centreline[i], b = r.centreline[i + 1];
        const dx = b[0] - a[0], dy = b[1] - a[1];
        const u = Math.max(0, Math.min(1, ((x - a[0]) * dx + (y - a[1]) * dy) / (dx * dx + dy * dy || 1)));
        const d = Math.hypot(a[0] + u * dx - x, a[1] + u * dy - y);
        if (!best || d < best.d) best = { d, z: a[2] + u * (b[2] - a[2]) };
      }
    }
    const r = state.robots.get($('robot').value);
    sendGoal([x, y, (best ? best.z : 0) + (r ? r.radius : 0.4) + 0.6]);
  });

  function sendGoal(goal) {
    state.goalMode = false;
    $('goalmode').setAttribute('aria-pressed', 'false');
    command({ kind: 'goal', goal: goal.map((v) => Math.round(v * 100) / 100) });
  }

  // ----- replay ------------------------------------------------------------------------------
  $('load').onclick = async () => {
    const id = $('robot').value;
    if (!id) return;
    const messages = [];
    for (let from = 1; ;) {
      const page = await (await authed(`/api/history?robot=${encodeURIComponent(id)}&from_seq=${from}&limit=10000`)).json();
      if (!Array.isArray(page) || page.length === 0) break;
      messages.push(...page.filter((m) => m.type === 'telemetry'));
      // An answer may stop short of the limit (8 MiB of messages): page on until an empty one.
      from = page[page.length - 1].seq + 1;
    }
    if (!messages.length) { $('answer').textContent = 'no stored telemetry for ' + id; return; }
    state.replay = { robot: id, messages, trail: [], current: messages[0] };
    $('live').checked = false;
    const slider = $('slider');
    slider.max = String(messages.length - 1);
    slider.value = '0';
    slider.disabled = false;
    seek(0);
  };
  function seek(i) {
    const rp = state.replay;
    rp.current = rp.messages[i];
    rp.trail = rp.messages.slice(Math.max(0, i - TRAIL_MAX), i + 1).map((m) => m.pose);
    $('clock').textContent = `t = ${Number(rp.current.t).toFixed(1)} s`;
    robot(rp.robot).dirty = true;
  }
  $('slider').oninput = (e) => state.replay && seek(Number(e.target.value));
  $('live').onchange = (e) => {
    if (!e.target.checked && !state.replay) { e.target.checked = true; return; }
    if (e.target.checked && state.replay) {
      const id = state.replay.robot;
      state.replay = null;
      $('slider').disabled = true;
      robot(id).dirty = true;
    }
  };

  // ----- start -------------------------------------------------------------------------------
  async function start() {
    let map, mesh;
    for (;;) {
      if (token.value.trim()) {
        const res = await Promise.all([authed('/api/map'), authed('/api/map/mesh')]);
        if (res.every((r) => r.ok)) {
          [map, mesh] = await Promise.all(res.map((r) => r.json()));
          break;
        }
        if (!res.some((r) => r.status === 401)) throw new Error(`/api/map answered ${res[0].status}`);
        $('conn').textContent = 'wrong operator token';
      } else {
        $('conn').textContent = 'enter the operator token';
      }
      $('conn').className = 'bad';
      await new Promise((resolve) => token.addEventListener('change', resolve, { once: true }));
    }
    state.map = map;
    state.margin = map.alarms ? map.alarms.clearance : null;
    $('mapname').textContent = `${map.name} (${map.roadways.length} roadways, resolution ${map.resolution} m)`;
    for (const r of map.roadways) {
      const option = document.createElement('option');
      option.value = option.textContent = r.name;
      $('roadway').appendChild(option);
    }
    setUp3d(map, mesh);
    connect();
    root.dataset.ready = '1';
    requestAnimationFrame(frame);
  }
  start().catch((e) => fail('start: ' + e));
})();
