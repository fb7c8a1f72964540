// The orientation and model options of every prediction, and the page's words for who chose: which
// orientation source ran and why, which model and by which rule ("you chose" it, or the server did:
// the default, and why it is the default, or the model for the recording's kind).

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
  if (m) {
    // The model's short summary (GET /models, at most 25 words) where it has one, not the long why.
    const info = (typeof state !== "undefined" ? state.models : []).find((x) => x.name === m.model);
    const summary = info && info.summary;
    // With a summary: the reason's first clause ("a phone app's export (sensorlogger)"), not its story.
    const clause = m.reason.split(": ")[0];
    const forThis = summary && clause.length < 80 ? `${clause}; ${summary}` : m.reason;
    const who = m.rule === "requested" ? "you chose"
      : m.rule === "default" ? `default: ${summary || m.reason}` : `chosen for this recording: ${forThis}`;
    parts.push(`Model: ${m.model} (${who}).`);
  }
  return parts.join(" ");
}

// "&model=...": only when the user picked a model; the first option ("default: ...") names none, so
// the server chooses (the model trained on the recording's kind, else the default) and says so.
function modelParam() {
  const select = document.getElementById("model-select");
  return select && select.value ? `&model=${encodeURIComponent(select.value)}` : "";
}

// The model select's first option: the default by name (the select fits it); why, under the select.
function defaultOption(model, why) {
  const option = document.createElement("option");
  option.value = "";
  option.selected = true;
  option.textContent = `default: ${model.display_name || model.name}`;
  option.title = why || option.textContent;
  return option;
}

// Under the select while the default is chosen: what the server does with no model named.
function defaultModelWords() {
  return "No model named: the server runs the model trained on the recording's kind when it recognises " +
    "it, else the default. ";
}

function showChoices(result) {
  const element = document.getElementById("choice-text");
  if (element) element.textContent = choiceText(result);
  if (element) element.title = result.model_choice ? result.model_choice.reason : ""; // the whole why
}
