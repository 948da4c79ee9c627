// SPDX-License-Identifier: BSD-3-Clause
// Clicks every mark of an animated page's timeline as a user would and records the outcome in
// <html data-click="ok | what failed">: each click pauses the page on its event's frame, which
// names the event (data-event), and a replan's frame says "replanning"; the marks of events
// before it are drawn as past. Added to a copy of the page by page_variant.cmake.
(function () {
  var root = document.documentElement, failed = [];
  function attr(name) { return root.getAttribute(name); }
  function check(ok, what) { if (!ok) failed.push(what); }
  var marks = document.querySelectorAll('#marks .mark');
  check(marks.length > 0, 'no timeline marks');
  check(String(marks.length) === attr('data-events'), marks.length + ' marks for data-events=' + attr('data-events'));
  for (var k = 0; k < marks.length; ++k) {
    var m = marks[k], kind = m.getAttribute('data-kind'), want = m.getAttribute('data-frame');
    m.click();
    var where = 'mark ' + k + ' (' + kind + ' at ' + m.getAttribute('data-t') + ' s)';
    check(attr('data-frame') === want, where + ' showed frame ' + attr('data-frame') + ', not ' + want);
    check(attr('data-playing') === '0', where + ' did not pause');
    check((' ' + attr('data-event') + ' ').indexOf(' ' + kind + ' ') >= 0, where + ': data-event is "' + attr('data-event') + '"');
    if (kind === 'replan') check(attr('data-status') === 'replanning', where + ': status "' + attr('data-status') + '"');
    check(m.classList.contains('now'), where + ' is not marked as the moment shown');
    check(k === 0 || marks[k - 1].getAttribute('data-frame') === want || marks[k - 1].classList.contains('past'),
          where + ': the mark before it is not drawn as past');
  }
  root.setAttribute('data-click', failed.length ? failed.join('; ') : 'ok');
})();
