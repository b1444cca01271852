#!/usr/bin/python3
"""The relighting page in a real browser (headless Chromium through Selenium).

Precomputes a small operator, starts `polyrad serve --port 0`, loads the page, drags a light's
intensity slider, waits for the image, and checks that the image changed, that the page never
had more than one request in flight, that the image shown is the one for the slider's final
position, and that its pixels are those `polyrad relight -o X.png` writes for the same emission
and exposure. A screenshot is kept in --out. Exit 0 on success (ctest runs it).
"""
import argparse
import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

# Counts the page's requests to /api/relight in flight, installed before any of its scripts
# run; __relightDelayMs holds each answer back, as a slow server would, so that a drag makes
# changes faster than answers come and the page has to coalesce them.
FETCH_PROBE = """
window.__relightInFlight = 0; window.__relightMaxInFlight = 0; window.__relightSent = 0;
window.__relightDelayMs = 0;
const __fetch = window.fetch.bind(window);
window.fetch = async (url, init) => {
  const counted = String(url).includes('/api/relight');
  if (counted) {
    window.__relightSent++;
    window.__relightMaxInFlight = Math.max(window.__relightMaxInFlight, ++window.__relightInFlight);
  }
  try {
    const res = await __fetch(url, init);
    if (counted && window.__relightDelayMs) await new Promise((r) => setTimeout(r, window.__relightDelayMs));
    return res;
  } finally { if (counted) window.__relightInFlight--; }
};
"""

# The displayed image's pixels, read back through a canvas (RGBA, row-major).
READ_PIXELS = """
const img = document.getElementById('image');
const c = document.createElement('canvas');
c.width = img.naturalWidth; c.height = img.naturalHeight;
const ctx = c.getContext('2d');
ctx.drawImage(img, 0, 0);
return [c.width, c.height, Array.from(ctx.getImageData(0, 0, c.width, c.height).data)];
"""


def fail(message):
    print('FAILED: ' + message, file=sys.stderr)
    sys.exit(1)


def decode_png(path):
    """8-bit RGB or RGBA PNG -> (width, height, channels, bytes), without any imaging library."""
    data = open(path, 'rb').read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        fail(path + ' is not a PNG')
    pos, idat, width = 8, b'', 0
    while pos < len(data):
        length, kind = struct.unpack('>I4s', data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        if kind == b'IHDR':
            width, height, depth, colour, _, _, interlace = struct.unpack('>IIBBBBB', chunk)
            if depth != 8 or colour not in (2, 6) or interlace:
                fail(f'{path}: only 8-bit RGB(A) PNGs are read here')
            channels = 3 if colour == 2 else 4
        elif kind == b'IDAT':
            idat += chunk
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = width * channels
    out = bytearray()
    previous = bytearray(stride)
    for y in range(height):
        row = raw[y * (stride + 1):(y + 1) * (stride + 1)]
        kind, line = row[0], bytearray(row[1:])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = previous[i]
            c = previous[i - channels] if i >= channels else 0
            if kind == 1:
                line[i] = (line[i] + a) & 255
            elif kind == 2:
                line[i] = (line[i] + b) & 255
            elif kind == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        out += line
        previous = line
    return width, height, channels, bytes(out)


def small_scene(scenes, work):
    """cornell-box with a 64 x 48 camera and a second lamp, as the C++ serve tests use."""
    text = open(os.path.join(scenes, 'cornell-box.json')).read()
    text = text.replace('"width": 256, "height": 256', '"width": 64, "height": 48')
    lamp2 = ('{"name": "lamp2", "material": "lamp", "emission": [2, 4, 8], "polygon": '
             '[[400, 300, 559], [300, 300, 559], [300, 400, 559], [400, 400, 559]]},\n    ')
    text = text.replace('{"name": "light"', lamp2 + '{"name": "light"')
    shutil.copytree(os.path.join(scenes, 'meshes'), os.path.join(work, 'meshes'))
    path = os.path.join(work, 'box.json')
    open(path, 'w').write(text)
    return path


def start_server(polyrad, prt):
    server = subprocess.Popen([polyrad, '--quiet', 'serve', prt, '--port', '0'],
                              stderr=subprocess.PIPE, text=True)
    line = server.stderr.readline().strip()
    prefix = 'polyrad: serving http://127.0.0.1:'
    if not line.startswith(prefix):
        server.kill()
        fail('the server said ' + repr(line))
    return server, 'http://127.0.0.1:' + line[len(prefix):]


def start_browser(profile):
    options = webdriver.ChromeOptions()
    for flag in ('--headless', '--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run',
                 '--disable-background-networking', '--disable-component-update', '--disable-sync',
                 '--disable-dev-shm-usage', '--window-size=1200,900',
                 '--user-data-dir=' + profile):
        options.add_argument(flag)
    options.binary_location = shutil.which('chromium') or '/usr/bin/chromium'
    driver = webdriver.Chrome(service=Service('/usr/bin/chromedriver'), options=options)
    driver.execute_cdp_cmd('Page.addScriptToEvaluateOnNewDocument', {'source': FETCH_PROBE})
    return driver


def wait_idle(driver, frames_above):
    WebDriverWait(driver, 60, poll_frequency=0.05).until(
        lambda d: d.execute_script('return window.polyrad && window.polyrad.idle() && '
                                   'window.polyrad.frames > arguments[0]', frames_above))
    return driver.execute_script('return window.polyrad.frames')


def relight_reference(polyrad, prt, request, path):
    args = [polyrad, '--quiet', 'relight', prt, '-o', path, '--exposure', repr(request['exposure'])]
    for name, rgb in request['emission'].items():
        args += ['--emission', name + '=' + ','.join(repr(float(c)) for c in rgb)]
    subprocess.run(args, check=True)
    return decode_png(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument('--polyrad', required=True)
    ap.add_argument('--scenes', required=True)
    ap.add_argument('--out', required=True)
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix='polyrad-browser-')
    server = driver = None
    try:
        prt = os.path.join(work, 'box.prt')
        subprocess.run([a.polyrad, '--quiet', 'precompute', small_scene(a.scenes, work), '-o', prt,
                        '--patch-size', '150', '--order', '6'], check=True)
        server, url = start_server(a.polyrad, prt)
        driver = start_browser(os.path.join(work, 'profile'))
        driver.get(url)
        frames = wait_idle(driver, 0)
        w, h, before = driver.execute_script(READ_PIXELS)
        if (w, h) != (64, 48):
            fail(f'the image is {w} x {h}, not 64 x 48')

        # Drag the lamp's intensity slider to the right, in steps, as a hand would, with each
        # answer held back 100 ms.
        driver.execute_script('window.__relightDelayMs = 100')
        slider = driver.find_element(By.CSS_SELECTOR, 'input[data-light="light"]')
        chain = ActionChains(driver, duration=10).click_and_hold(slider)
        for _ in range(12):
            chain.move_by_offset(6, 0).pause(0.02)
        chain.release().perform()
        frames = wait_idle(driver, frames)
        time.sleep(0.3)  # nothing more may come
        frames = wait_idle(driver, frames - 1)

        state = driver.execute_script(
            'return [window.polyrad.lastRequest, window.polyrad.changes, window.__relightSent, '
            'window.__relightMaxInFlight, document.querySelector(\'input[data-light="light"]\').value, '
            'document.getElementById("product-ms").textContent]')
        last, changes, sent, max_in_flight, slider_value, product_text = state
        request = json.loads(last)
        print(f'{changes} changes, {sent} requests, {frames} frames, at most {max_in_flight} in flight; '
              f'product {product_text}')
        if max_in_flight != 1:
            fail(f'{max_in_flight} requests were in flight at once')
        if sent >= changes:
            fail(f'{sent} requests for {changes} changes: nothing was coalesced')
        if abs(max(request['emission']['light']) - float(slider_value)) > 1e-9:
            fail(f'the image shown is for {request["emission"]["light"]}, the slider says {slider_value}')
        if request['emission']['light'] == [17, 12, 4]:
            fail('the slider did not change the emission')

        w, h, after = driver.execute_script(READ_PIXELS)
        if after == before:
            fail('the image did not change')
        rw, rh, channels, ref = relight_reference(a.polyrad, prt, request, os.path.join(a.out, 'relight.png'))
        shown = bytes(v for i, v in enumerate(after) if i % 4 != 3)  # RGBA -> RGB
        ref_rgb = ref if channels == 3 else bytes(v for i, v in enumerate(ref) if i % 4 != 3)
        if (rw, rh) != (w, h) or shown != ref_rgb:
            worst = max(abs(x - y) for x, y in zip(shown, ref_rgb)) if len(shown) == len(ref_rgb) else 'size'
            fail(f'the page shows other pixels than polyrad relight writes (largest difference {worst})')
        driver.save_screenshot(os.path.join(a.out, 'serve-page.png'))
        print('the page relit as polyrad relight does; screenshot in ' + os.path.join(a.out, 'serve-page.png'))
    finally:
        if driver:
            driver.quit()
        if server:
            server.send_signal(signal.SIGTERM)
            try:
                code = server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                code = 'a hang'
            if code != 0:
                print(server.stderr.read(), file=sys.stderr)
                fail(f'the server ended with {code} on SIGTERM')
        shutil.rmtree(work, ignore_errors=True)


if __name__ == '__main__':
    main()
