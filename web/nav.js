// The one navigation bar of every dashboard page (index, calibrate,
// experiment): written into <header><nav> as the page loads, so the pages
// cannot drift apart. On the index page the links are its views (#/home …)
// and app.js marks the active one; on the others the page's own link is.
"use strict";
(function writeNavigation() {
  const nav = document.querySelector("header nav");
  if (!nav) return;
  const onIndex = location.pathname === "/";
  const links = [
    ["Home", "home"], ["Live", "live"], ["Measurements", "measurements"], ["Scenes", "scenes"],
    ["Viewer", "viewer"], ["Study", "study"], ["Material", "material"],
    ["Calibrate", null, "/calibrate"], ["Experiment", null, "/experiment"],
  ];
  nav.innerHTML = "";
  for (const [label, view, path] of links) {
    const a = document.createElement("a");
    a.textContent = label;
    if (view) {
      a.href = onIndex ? `#/${view}` : `/#/${view}`;
      a.dataset.view = view;
    } else {
      a.href = path;
      if (location.pathname === path) a.classList.add("active");
    }
    nav.appendChild(a);
  }
})();
