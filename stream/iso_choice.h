// How an extraction's iso value is chosen: a number, Otsu's threshold on the volume's streamed
// histogram ("auto"), or a named Hounsfield value for CT ("bone", "skin").
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>

#include "io/slice_source.h"
#include "stream/value_histogram.h"

namespace isoslab {

/// A Hounsfield value taken by name.
struct NamedIso {
  const char* name = "";
  double hounsfield = 0;
};

/// The named values: bone 300 HU, skin -400 HU.
inline constexpr std::array<NamedIso, 2> kNamedIsos{{{"bone", 300.0}, {"skin", -400.0}}};

/// The bins of the histogram that "auto" splits (scikit-image's default too).
inline constexpr std::size_t kAutoIsoBins = 256;

/// What the user asked for.
struct IsoRequest {
  enum class Kind { kValue, kAuto, kNamed };
  Kind kind = Kind::kValue;
  double value = 0;  // kValue
  NamedIso named;    // kNamed
};

/// A finite number (the whole text, as strtod reads it), "auto", or a name of kNamedIsos, in any
/// case; empty for anything else.
std::optional<IsoRequest> parseIsoRequest(const std::string& text);

struct IsoChoice {
  double value = 0;
  /// How the value was chosen, for a report: "value", "auto (Otsu, 256 bins)", "bone (300 HU)".
  std::string source;
  /// One line for the user without a prefix, naming the setting as `iso` (core/error.h); empty for
  /// a number.
  std::string note;
  /// "auto": the histogram and its split.
  std::optional<ValueHistogram> histogram;
  std::optional<OtsuSplit> split;
  /// Whether `source` has been read to its end ("auto"): an extraction then needs a fresh one.
  bool sourceRead = false;
};

/// Resolves `request` for the volume of `source`; `input` names it in messages.
/// - kValue: the value.
/// - kAuto: otsuSplit(streamHistogram(source, kAutoIsoBins, reopen)).iso, which costs one pass over
///   the input (two when its range is unknown and it holds more than kExactValues distinct
///   values) before the extraction. Throws isoslab::Error when no split exists (one finite value,
///   or none).
/// - kNamed: the Hounsfield value when the input's modality is CT, or when it names none (raw,
///   NIfTI, NRRD, phantoms: the note then says that the value is taken as Hounsfield units).
///   Throws isoslab::Error for any other modality.
IsoChoice chooseIso(const IsoRequest& request, const std::string& input, SliceSource& source,
                    const SourceOpener& reopen);

}  // namespace isoslab
