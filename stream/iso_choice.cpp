#include "stream/iso_choice.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "core/error.h"

namespace isoslab {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

IsoChoice autoIso(const std::string& input, SliceSource& source, const SourceOpener& reopen) {
  IsoChoice choice;
  choice.histogram = streamHistogram(source, kAutoIsoBins, reopen);
  choice.sourceRead = true;
  const ValueHistogram& h = *choice.histogram;
  choice.split = otsuSplit(h);
  if (!choice.split) {
    if (!h.finiteRange) throw Error(fmt::format("{}: `iso` auto: the input holds no finite value", input));
    const auto& r = *h.finiteRange;
    throw Error(fmt::format("{}: `iso` auto: no threshold separates the values: {}", input,
                            r[0] == r[1] ? fmt::format("every finite value is {}", r[0])
                                         : fmt::format("every finite value lies in one of {} bins", h.bins())));
  }
  choice.value = choice.split->iso;
  choice.source = fmt::format("auto (Otsu, {} bins)", h.bins());
  choice.note = fmt::format("`iso` auto: Otsu threshold {} over {} bins of {} .. {} ({} {} over the input)",
                            choice.value, h.bins(), h.lo, h.hi, h.passes, h.passes == 1 ? "pass" : "passes");
  return choice;
}

}  // namespace

std::optional<IsoRequest> parseIsoRequest(const std::string& text) {
  IsoRequest request;
  const std::string name = lower(text);
  if (name == "auto") {
    request.kind = IsoRequest::Kind::kAuto;
    return request;
  }
  for (const NamedIso& named : kNamedIsos) {
    if (name == named.name) {
      request.kind = IsoRequest::Kind::kNamed;
      request.named = named;
      return request;
    }
  }
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || (errno == ERANGE && std::abs(v) > 1)) {
    return std::nullopt;
  }
  request.value = v;
  return request;
}

IsoChoice chooseIso(const IsoRequest& request, const std::string& input, SliceSource& source,
                    const SourceOpener& reopen) {
  if (request.kind == IsoRequest::Kind::kAuto) return autoIso(input, source, reopen);
  IsoChoice choice;
  if (request.kind == IsoRequest::Kind::kValue) {
    choice.value = request.value;
    choice.source = "value";
    return choice;
  }
  const NamedIso& named = request.named;
  const std::string modality = source.info().modality;
  choice.value = named.hounsfield;
  choice.source = fmt::format("{} ({} HU)", named.name, named.hounsfield);
  if (lower(modality) == "ct") {
    choice.note = fmt::format("`iso` {}: {} HU (the input is CT)", named.name, named.hounsfield);
  } else if (modality.empty()) {
    choice.note = fmt::format("`iso` {}: {}, taken as Hounsfield units (the input names no modality)", named.name,
                              named.hounsfield);
  } else {
    throw Error(
        fmt::format("{}: `iso` {} means {} HU, a CT value, but the input's modality is {}; give the iso "
                    "value as a number",
                    input, named.name, named.hounsfield, modality));
  }
  return choice;
}

}  // namespace isoslab
