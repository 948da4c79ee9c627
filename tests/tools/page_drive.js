// SPDX-License-Identifier: BSD-3-Clause
// Works an animated page's controls as a user would and records the outcome in
// <html data-drive="ok | what failed">; added to a copy of the page by page_variant.cmake.
(function () {
  var root = document.documentElement, failed = [];
  function $(id) { return document.getElementById(id); }
  function attr(name) { return root.getAttribute(name); }
  function check(ok, what) { if (!ok) failed.push(what); }
  function key(k) { document.dispatchEvent(new KeyboardEvent('keydown', { key: k, bubbles: true })); }
  var slider = $('slider'), last = String(Number(slider.max));

  check(attr('data-playing') === '1', 'the page did not start playing');
  $('play').click();
  check(attr('data-playing') === '0', 'the play button did not pause');
  slider.value = '100';
  slider.dispatchEvent(new Event('input'));
  check(attr('data-frame') === '100', 'the slider did not show frame 100 (' + attr('data-frame') + ')');
  check($('clock').textContent === 't = 10.0 s', 'the clock reads "' + $('clock').textContent + '" at frame 100');
  key('ArrowRight');
  check(attr('data-frame') === '101', 'the right arrow did not step to frame 101');
  key('ArrowLeft');
  key('ArrowLeft');
  check(attr('data-frame') === '99', 'the left arrow did not step back to frame 99');
  // "routes ahead": the movers' routes after the frame shown, only while ticked.
  var ahead = $('ahead');
  if (ahead) {
    var tc = $('tracks'), tctx = tc.getContext('2d');
    var inked = function () {
      var d = tctx.getImageData(0, 0, tc.width, tc.height).data;
      for (var i = 3; i < d.length; i += 4) if (d[i]) return true;
      return false;
    };
    check(!inked(), 'routes ahead were drawn before "routes ahead" was ticked');
    ahead.click();
    check(inked(), 'ticking "routes ahead" drew no route');
    ahead.click();
    check(!inked(), 'unticking "routes ahead" left the routes drawn');
  }
  key('End');
  check(attr('data-frame') === last, 'End did not show the last frame');
  check(attr('data-playing') === '0', 'stepping did not pause');
  $('play').click();
  check(attr('data-frame') === '0' && attr('data-playing') === '1', 'play at the end did not restart from frame 0');
  $('speed').value = '10';
  root.setAttribute('data-drive', failed.length ? failed.join('; ') : 'ok');
})();
