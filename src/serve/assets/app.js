// The relighting page: one control per light, exposure, the camera orbit for solution
// operators, and the image, fetched from POST /api/relight.
//
// Requests are coalesced: at most one is in flight; changes made meanwhile only mark the state
// dirty, and when the answer arrives the latest state alone is sent. A slider dragged for a
// second therefore costs as many products as the server can answer in that second, and the
// image never lags behind through a queue of stale frames.
'use strict';

const $ = (id) => document.getElementById(id);

const state = {
  operator: null,
  lights: [],          // {name, scene: [r,g,b], on, colour: [r,g,b] | null, intensity: number | null, ...}
  exposureStops: 0,
  yaw: 0,
  pitch: 0,
};

// What the tests (and a curious reader of the console) can look at.
const polyrad = window.polyrad = {
  frames: 0,           // images shown
  changes: 0,          // changes asked for
  inFlight: false,
  dirty: false,
  lastRequest: null,   // the JSON text of the request behind the image shown
  lastBlob: null,      // that image
  idle() { return !this.inFlight && !this.dirty && this.frames > 0; },
};

const maxOf = (rgb) => Math.max(rgb[0], rgb[1], rgb[2]);

function toHex(rgb) {
  return '#' + rgb.map((c) => Math.round(255 * Math.min(1, Math.max(0, c))).toString(16).padStart(2, '0')).join('');
}

function fromHex(hex) {
  return [1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16) / 255);
}

// A light's emission: exactly the scene's until its colour or intensity is moved.
function emissionOf(light) {
  if (!light.on) return [0, 0, 0];
  if (light.colour === null && light.intensity === null) return light.scene.slice();
  const m = maxOf(light.scene);
  const colour = light.colour ?? (m > 0 ? light.scene.map((c) => c / m) : [1, 1, 1]);
  const k = light.intensity ?? m;
  return colour.map((c) => c * k);
}

function exposure() { return Math.pow(2, state.exposureStops); }

function currentRequest() {
  const emission = {};
  for (const l of state.lights) emission[l.name] = emissionOf(l);
  const req = { emission, exposure: exposure(), format: 'png' };
  if (state.operator.orbit) req.camera = { yaw: state.yaw, pitch: state.pitch };
  return req;
}

function showStatus(text, isError) {
  $('status').textContent = text;
  $('status').classList.toggle('error', !!isError);
}

const ms = (x) => (x === null || x === undefined || x === '' ? '–' : Number(x).toFixed(2) + ' ms');

async function showImage(blob) {
  const url = URL.createObjectURL(blob);
  const img = $('image');
  const old = img.src;
  img.src = url;
  try { await img.decode(); } catch (e) { /* shown anyway once loaded */ }
  if (old.startsWith('blob:')) URL.revokeObjectURL(old);
}

// ---- coalescing: at most one request in flight, then only the latest state ---------------------

function requestFrame() {
  polyrad.changes++;
  polyrad.dirty = true;
  if (!polyrad.inFlight) send();
}

async function send() {
  polyrad.dirty = false;
  polyrad.inFlight = true;
  const body = JSON.stringify(currentRequest());
  const t0 = performance.now();
  try {
    const res = await fetch('/api/relight', {
      method: 'POST', headers: { 'Content-Type': 'application/json' }, body,
    });
    if (!res.ok) {
      const err = await res.json().catch(() => ({ error: res.statusText }));
      showStatus(`The server refused the request (${res.status}): ${err.error}`, true);
    } else {
      const blob = await res.blob();
      await showImage(blob);
      polyrad.frames++;
      polyrad.lastRequest = body;
      polyrad.lastBlob = blob;
      $('product-ms').textContent = ms(res.headers.get('X-Polyrad-Product-Ms'));
      $('encode-ms').textContent = ms(res.headers.get('X-Polyrad-Encode-Ms'));
      $('gather-ms').textContent = ms(res.headers.get('X-Polyrad-Gather-Ms')) +
        (res.headers.get('X-Polyrad-Gather-Built') === '1' ? ' (rebuilt for the camera)' : '');
      $('round-trip-ms').textContent = ms(performance.now() - t0);
      $('frames').textContent = `${polyrad.frames} shown for ${polyrad.changes} changes`;
      showStatus('');
    }
  } catch (e) {
    showStatus('The server cannot be reached: ' + e.message, true);
  } finally {
    polyrad.inFlight = false;
    if (polyrad.dirty) send();
  }
}

// ---- controls ---------------------------------------------------------------------------------

function element(tag, attributes = {}, children = []) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attributes)) e.setAttribute(k, v);
  for (const c of children) e.append(c);
  return e;
}

function lightControls(light, index) {
  const m = maxOf(light.scene);
  const top = m > 0 ? 4 * m : 1;
  const on = element('input', { type: 'checkbox', id: `on-${index}` });
  on.checked = true;
  const colour = element('input', { type: 'color', id: `colour-${index}`, 'aria-label': `Colour of ${light.name}` });
  const intensity = element('input', {
    type: 'range', id: `intensity-${index}`, min: '0', max: String(top), step: String(top / 400),
    'data-light': light.name, 'aria-label': `Intensity of ${light.name}`,
  });
  const value = element('output', { id: `intensity-value-${index}` });
  light.controls = { on, colour, intensity, value };
  on.addEventListener('input', () => { light.on = on.checked; requestFrame(); });
  colour.addEventListener('input', () => { light.colour = fromHex(colour.value); requestFrame(); });
  intensity.addEventListener('input', () => {
    light.intensity = Number(intensity.value);
    value.textContent = light.intensity.toFixed(2);
    requestFrame();
  });
  return element('fieldset', { class: 'light' }, [
    element('legend', {}, [light.name]),
    element('label', { class: 'row' }, [on, 'on', colour]),
    element('label', {}, ['Intensity', intensity, value]),
  ]);
}

// Puts every control at the scene's values (the state itself is reset by the caller).
function syncControls() {
  for (const l of state.lights) {
    const m = maxOf(l.scene);
    l.controls.on.checked = l.on;
    l.controls.colour.value = toHex(m > 0 ? l.scene.map((c) => c / m) : [1, 1, 1]);
    l.controls.intensity.value = String(m);
    l.controls.value.textContent = m.toFixed(2);
  }
  $('exposure').value = String(state.exposureStops);
  $('exposure-value').textContent = exposure().toFixed(2);
  $('yaw').value = String(state.yaw);
  $('pitch').value = String(state.pitch);
  $('yaw-value').textContent = `${state.yaw}°`;
  $('pitch-value').textContent = `${state.pitch}°`;
}

function reset() {
  for (const l of state.lights) Object.assign(l, { on: true, colour: null, intensity: null });
  state.exposureStops = 0;
  state.yaw = 0;
  state.pitch = 0;
  syncControls();
  requestFrame();
}

function setOrbit(yaw, pitch) {
  state.yaw = Math.round(((yaw + 540) % 360) - 180);
  state.pitch = Math.round(Math.max(-80, Math.min(80, pitch)));
  $('yaw').value = String(state.yaw);
  $('pitch').value = String(state.pitch);
  $('yaw-value').textContent = `${state.yaw}°`;
  $('pitch-value').textContent = `${state.pitch}°`;
  requestFrame();
}

// Dragging the image orbits the camera (solution operators).
function orbitByDragging(img) {
  img.classList.add('orbit');
  let from = null;
  img.addEventListener('pointerdown', (e) => {
    from = { x: e.clientX, y: e.clientY, yaw: state.yaw, pitch: state.pitch };
    img.setPointerCapture(e.pointerId);
    e.preventDefault();
  });
  img.addEventListener('pointermove', (e) => {
    if (!from) return;
    const degreesPerPixel = 180 / img.clientWidth;
    setOrbit(from.yaw - (e.clientX - from.x) * degreesPerPixel, from.pitch + (e.clientY - from.y) * degreesPerPixel);
  });
  const end = () => { from = null; };
  img.addEventListener('pointerup', end);
  img.addEventListener('pointercancel', end);
}

function describe(op) {
  const mb = (op.bytes / 1e6).toFixed(1);
  return `${op.width} × ${op.height}, ${op.output} operator of order ${op.order}, ` +
         `${op.columns} columns, ${mb} MB. ${op.lights.length} light${op.lights.length === 1 ? '' : 's'}.`;
}

async function start() {
  let op;
  try {
    const res = await fetch('/api/operator');
    op = await res.json();
  } catch (e) {
    showStatus('Cannot read the operator: ' + e.message, true);
    return;
  }
  state.operator = op;
  $('summary').textContent = describe(op);
  document.documentElement.style.setProperty('--aspect', `${op.width} / ${op.height}`);
  state.lights = op.lights.map((l) => ({ name: l.name, scene: l.emission, on: true, colour: null, intensity: null }));
  $('lights').replaceChildren(...state.lights.map(lightControls));
  $('exposure').addEventListener('input', () => {
    state.exposureStops = Number($('exposure').value);
    $('exposure-value').textContent = exposure().toFixed(2);
    requestFrame();
  });
  if (op.orbit) {
    $('orbit').hidden = false;
    $('gather-row').hidden = false;
    $('yaw').addEventListener('input', () => setOrbit(Number($('yaw').value), state.pitch));
    $('pitch').addEventListener('input', () => setOrbit(state.yaw, Number($('pitch').value)));
    orbitByDragging($('image'));
  }
  $('reset').addEventListener('click', reset);
  syncControls();
  showStatus('Rendering…');
  requestFrame();
}

start();
