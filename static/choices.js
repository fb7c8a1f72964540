// The orientation option of every prediction, and the page's words for what the server chose:
// which orientation source ran and why, which model and by which rule.

const ORIENTATION_SOURCE_WORDS = {
  device: "the phone's own attitude",
  vqf: "the VQF filter with the magnetometer (9-D)",
  vqf6d: "the VQF filter without the magnetometer (6-D)",
  ground_truth: "the ground truth's orientation (motion capture)",
};

// "&orientation=auto": the choice of the page's select, for every POST it makes.
function orientationParam() {
  const select = document.getElementById("orientation-select");
  return select && select.value ? `&orientation=${encodeURIComponent(select.value)}` : "";
}

// The orientation and model choices of a prediction, in words (empty when the answer has neither).
function choiceText(result) {
  const parts = [];
  const o = result.orientation_choice;
  if (o) {
    const what = ORIENTATION_SOURCE_WORDS[o.source] || o.source;
    const why = o.requested === "auto" ? `chosen automatically: ${o.reason}` : o.requested === o.source ? "as asked" : o.reason;
    parts.push(`Orientation: ${what} (${why}).`);
  }
  const m = result.model_choice;
  if (m) parts.push(`Model: ${m.model} (${m.rule === "requested" ? "as chosen" : m.reason}).`);
  return parts.join(" ");
}

function showChoices(result) {
  const element = document.getElementById("choice-text");
  if (element) element.textContent = choiceText(result);
}
