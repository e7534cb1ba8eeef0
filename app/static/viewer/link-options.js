// A <select> of a model's links, the default link selected (the links panel, the closed-form tip,
// the calibration link). (A module of the model viewer; viewer.js is the entry point.)

import { defaultLink } from "./defaults.js";

/** Fill `select` with the model's links (label(link): the text shown), the default link selected. */
export function fillLinkOptions(select, info, label = (link) => link) {
  select.replaceChildren();
  for (const link of info.links) {
    const opt = document.createElement("option");
    opt.value = link;
    opt.textContent = label(link);
    select.appendChild(opt);
  }
  select.value = defaultLink(info);
}
