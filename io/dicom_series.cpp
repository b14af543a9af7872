#include "io/dicom_series.h"

// DCMTK
#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfcache.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcpixel.h>
#include <dcmtk/dcmdata/dcpixseq.h>
#include <dcmtk/dcmdata/dcpxitem.h>
#include <dcmtk/dcmdata/dcrledrg.h>
#include <dcmtk/dcmdata/dctag.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmdata/dcxfer.h>
#include <dcmtk/dcmjpeg/djdecode.h>
#include <dcmtk/dcmjpls/djdecode.h>
#include <dcmtk/oflog/oflog.h>
#include <fmt/format.h>
#include <openjpeg.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numbers>
#include <numeric>
#include <set>

#include "core/error.h"
#include "core/limits.h"
#include "core/vec3.h"
#include "io/dicom_common.h"
#include "io/file_list.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

using namespace dicom;

constexpr double kInf = std::numeric_limits<double>::infinity();

// What the header pass keeps of one image file.
struct FileHeader {
  DicomSeries series;  // the series fields, with this file's slices
};

// The bytes of a DICOM file for the nesting walk, read forward: from the file, and, once the
// dataset of a deflated file starts, through zlib's inflate. Skips are lazy (a value is skipped by
// moving `pos`; the bytes are sought over, or inflated and dropped, only when more is read).
class WalkBytes {
 public:
  explicit WalkBytes(const std::string& path) : file_(path, std::ios::binary) {
    std::error_code ec;
    size_ = static_cast<std::uint64_t>(fs::file_size(path, ec));
    if (ec) file_.setstate(std::ios::failbit);
  }
  WalkBytes(const WalkBytes&) = delete;
  WalkBytes& operator=(const WalkBytes&) = delete;
  ~WalkBytes() {
    if (inflating_) inflateEnd(&z_);
  }
  bool good() const { return static_cast<bool>(file_); }
  std::uint64_t size() const { return size_; }

  // From here on the bytes are a raw deflate stream (RFC 1951) starting at file offset `pos`.
  bool startInflating() {
    z_ = z_stream{};
    if (inflateInit2(&z_, -MAX_WBITS) != Z_OK) return false;
    inflating_ = true;
    fileAt_ = pos;
    base_ = pos;
    produced_ = pos;  // positions stay continuous: the inflated bytes follow the meta group
    return true;
  }
  // Whether the inflated data passed `limit` bytes (the walk then stops).
  bool tooLarge() const { return tooLarge_; }

  std::uint64_t pos = 0;

  bool read(char* into, std::size_t n) {
    if (!inflating_) {
      if (pos + n > size_) return false;
      file_.seekg(static_cast<std::streamoff>(pos));
      if (!file_.read(into, static_cast<std::streamsize>(n))) return false;
      pos += n;
      return true;
    }
    while (produced_ < pos) {  // skip lazily
      char drop[16384];
      const auto k = static_cast<std::size_t>(std::min<std::uint64_t>(sizeof drop, pos - produced_));
      if (!inflateSome(drop, k)) return false;
    }
    if (!inflateSome(into, n)) return false;
    pos += n;
    return true;
  }

 private:
  // Inflates exactly `n` more bytes into `into`.
  bool inflateSome(char* into, std::size_t n) {
    if (produced_ - base_ + n > static_cast<std::uint64_t>(limits::kMaxInflatedDicomBytes)) {
      tooLarge_ = true;
      return false;
    }
    z_.next_out = reinterpret_cast<Bytef*>(into);
    z_.avail_out = static_cast<uInt>(n);
    while (z_.avail_out > 0) {
      if (z_.avail_in == 0) {
        if (fileAt_ >= size_) return false;
        file_.seekg(static_cast<std::streamoff>(fileAt_));
        const auto k = static_cast<std::streamsize>(std::min<std::uint64_t>(sizeof in_, size_ - fileAt_));
        if (!file_.read(in_, k)) return false;
        fileAt_ += static_cast<std::uint64_t>(k);
        z_.next_in = reinterpret_cast<Bytef*>(in_);
        z_.avail_in = static_cast<uInt>(k);
      }
      const int r = inflate(&z_, Z_NO_FLUSH);
      if (r == Z_STREAM_END && z_.avail_out > 0) return false;
      if (r != Z_OK && r != Z_STREAM_END) return false;
    }
    produced_ += n;
    return true;
  }

  std::ifstream file_;
  std::uint64_t size_ = 0;
  bool inflating_ = false;
  bool tooLarge_ = false;
  z_stream z_{};
  std::uint64_t fileAt_ = 0;    // next file offset to feed to inflate
  std::uint64_t base_ = 0;      // walk position of the first inflated byte
  std::uint64_t produced_ = 0;  // walk position of the next inflated byte
  char in_[16384];
};

// What the nesting walk found.
enum class Nesting { kWithin, kTooDeep, kTooLarge };

// Whether a DICOM file nests sequences deeper than `limit`. DCMTK's reader recurses once per
// level, so a crafted file of thousands of nested sequences would overflow the stack; this walk
// keeps its own stack. It reads tags and lengths only and skips over values. A deflated dataset is
// inflated as it is walked, up to limits::kMaxInflatedDicomBytes. Truncated or odd files stop the
// walk; DCMTK then reports them.
Nesting nesting(const std::string& path, int limit) {
  WalkBytes bytes(path);
  const std::uint64_t size = bytes.size();
  if (!bytes.good() || size < 132) return Nesting::kWithin;
  constexpr std::uint32_t kUndefined = 0xFFFFFFFFu;
  std::uint64_t& pos = bytes.pos;
  pos = 132;
  bool bigEndian = false, bigEndianDataset = false, explicitVr = true, deflated = false;
  std::optional<std::uint64_t> metaEnd;  // from the meta group's length (0002,0000)
  auto read = [&](char* into, std::size_t n) { return bytes.read(into, n); };
  auto stop = [&] { return bytes.tooLarge() ? Nesting::kTooLarge : Nesting::kWithin; };
  auto u16 = [&](const unsigned char* b) {
    return static_cast<std::uint16_t>(bigEndian ? (b[0] << 8) | b[1] : b[0] | (b[1] << 8));
  };
  auto u32 = [&](const unsigned char* b) {
    return bigEndian ? (std::uint32_t{b[0]} << 24) | (std::uint32_t{b[1]} << 16) | (std::uint32_t{b[2]} << 8) | b[3]
                     : b[0] | (std::uint32_t{b[1]} << 8) | (std::uint32_t{b[2]} << 16) | (std::uint32_t{b[3]} << 24);
  };
  // Containers open at `pos`: their end (none when of undefined length), and whether a sequence
  // (as opposed to an item, or encapsulated pixel data whose items are opaque fragments).
  struct Open {
    std::uint64_t end;
    enum Kind { kSequence, kItem, kFragments } kind;
  };
  std::vector<Open> open;
  int depth = 0;
  bool meta = true;
  for (;;) {
    while (!open.empty() && open.back().end <= pos) {
      if (open.back().kind == Open::kSequence) --depth;
      open.pop_back();
    }
    const std::uint64_t start = pos;
    unsigned char b[12];
    if (meta && metaEnd && start >= *metaEnd) {
      // The dataset starts where the meta group's length says (a deflate stream may begin with
      // bytes that look like group 0002).
      meta = false;
      bigEndian = bigEndianDataset;
      if (deflated && !bytes.startInflating()) return stop();
    }
    if (!read(reinterpret_cast<char*>(b), 4)) return stop();
    std::uint16_t group = u16(b);
    if (meta && group != 0x0002) {
      // The dataset starts: the meta group was explicit little endian; the rest follows the syntax.
      meta = false;
      bigEndian = bigEndianDataset;
      pos = start;
      if (deflated && !bytes.startInflating()) return stop();
      if (!read(reinterpret_cast<char*>(b), 4)) return stop();
      group = u16(b);
    }
    const std::uint16_t element = u16(b + 2);
    if (group == 0xFFFE) {
      if (!read(reinterpret_cast<char*>(b + 4), 4)) return stop();
      const std::uint32_t length = u32(b + 4);
      if (element == 0xE000) {
        if (!open.empty() && open.back().kind == Open::kFragments) {
          pos += length == kUndefined ? 0 : length;
        } else {
          open.push_back({length == kUndefined ? UINT64_MAX : pos + length, Open::kItem});
        }
      } else if (!open.empty() && (element == 0xE00D || element == 0xE0DD)) {
        if (open.back().kind == Open::kSequence) --depth;
        open.pop_back();
      }
      continue;
    }
    std::uint32_t length = 0;
    bool sequence = false;
    if (explicitVr || meta) {
      if (!read(reinterpret_cast<char*>(b + 4), 4)) return stop();
      const std::string vr(reinterpret_cast<const char*>(b + 4), 2);
      static const std::set<std::string> kLong = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ",
                                                  "SV", "UC", "UN", "UR", "UT", "UV"};
      if (kLong.count(vr)) {
        if (!read(reinterpret_cast<char*>(b + 8), 4)) return stop();
        length = u32(b + 8);
      } else {
        length = u16(b + 6);
      }
      sequence = vr == "SQ" || (vr == "UN" && length == kUndefined);
    } else {
      if (!read(reinterpret_cast<char*>(b + 4), 4)) return stop();
      length = u32(b + 4);
      sequence = length == kUndefined || DcmTag(group, element).getEVR() == EVR_SQ;
    }
    if (meta && group == 0x0002 && element == 0x0000 && length == 4) {
      unsigned char v[4];
      if (!read(reinterpret_cast<char*>(v), 4)) return stop();
      metaEnd = pos + u32(v);
      continue;
    }
    if (meta && group == 0x0002 && element == 0x0010 && length < 128) {
      std::string uid(length, '\0');
      if (!read(uid.data(), length)) return stop();
      while (!uid.empty() && (uid.back() == '\0' || uid.back() == ' ')) uid.pop_back();
      deflated = uid == UID_DeflatedExplicitVRLittleEndianTransferSyntax;
      explicitVr = uid != UID_LittleEndianImplicitTransferSyntax;
      bigEndianDataset = uid == UID_BigEndianExplicitTransferSyntax;  // from the dataset on
      continue;
    }
    if (group == 0x7FE0 && element == 0x0010 && length == kUndefined) {
      open.push_back({UINT64_MAX, Open::kFragments});
    } else if (sequence) {
      open.push_back({length == kUndefined ? UINT64_MAX : pos + length, Open::kSequence});
      if (++depth > limit) return Nesting::kTooDeep;
    } else if (length != kUndefined) {
      pos += length;
    }
  }
}

// The message for a file that DCMTK must not read, or empty.
std::string nestingProblem(const std::string& path) {
  switch (nesting(path, limits::kMaxDicomSequenceDepth)) {
    case Nesting::kTooDeep:
      return fmt::format("{}: sequences nest deeper than the limit of {} levels", path, limits::kMaxDicomSequenceDepth);
    case Nesting::kTooLarge:
      return fmt::format("{}: the deflated dataset inflates to more than the limit of {} bytes", path,
                         limits::kMaxInflatedDicomBytes);
    case Nesting::kWithin:
      break;
  }
  return {};
}

std::vector<std::string> dicomdirFiles(const std::string& path) {
  initDcmtk();
  if (const std::string problem = nestingProblem(path); !problem.empty()) throw Error(problem);
  DcmFileFormat ff;
  const OFCondition c = ff.loadFile(path.c_str());
  if (c.bad()) throw Error(fmt::format("{}: not a readable DICOMDIR: {}", path, c.text()));
  std::vector<std::string> files;
  DcmDataset* ds = ff.getDataset();
  const fs::path base = fs::path(path).parent_path();
  for (unsigned long i = 0;; ++i) {
    DcmItem* record = nullptr;
    if (ds->findAndGetSequenceItem(DCM_DirectoryRecordSequence, record, static_cast<signed long>(i)).bad()) break;
    OFString id;
    if (record->findAndGetOFStringArray(DCM_ReferencedFileID, id).bad() || id.empty()) continue;
    std::string rel(id.c_str());
    std::replace(rel.begin(), rel.end(), '\\', '/');
    files.push_back((base / rel).string());
  }
  return files;
}

// How far a gap may exceed the slices' thickness and still be covered by them: positions and
// SliceThickness are often rounded to 0.01 mm and 0.1 mm.
double thicknessTolerance(double thickness) {
  return std::max(0.02, 0.02 * thickness);
}

std::string seriesLabel(const DicomSeries& s) {
  return fmt::format("series {}", s.uid);
}

// What is wrong with an image's pixel description, or empty: the pixel reader masks and shifts by
// BitsStored, so it must be 1..BitsAllocated with HighBit one below it.
std::string pixelModuleProblem(std::uint16_t bitsAllocated, std::uint16_t bitsStored, std::uint16_t highBit,
                               std::uint16_t samplesPerPixel) {
  if (bitsAllocated == 0) return "BitsAllocated is 0";
  if (bitsStored == 0) return "BitsStored is 0";
  if (bitsStored > bitsAllocated) {
    return fmt::format("BitsStored {} is more than BitsAllocated {}", bitsStored, bitsAllocated);
  }
  if (highBit + 1 != bitsStored) {
    return fmt::format("HighBit {} does not match BitsStored {} (it must be {})", highBit, bitsStored, bitsStored - 1);
  }
  if (samplesPerPixel == 0) return "SamplesPerPixel is 0";
  return {};
}

// What is wrong with the length of uncompressed pixel data, or empty. The standard makes it
// Rows x Columns x SamplesPerPixel x BitsAllocated bits per frame (bit-packed when BitsAllocated
// is 1), in bytes rounded up, padded to an even length. Longer data would be read as its first
// part (half a head, or 16-bit values as 8-bit ones), shorter data past its end.
std::string pixelDataLengthProblem(const DicomSeries& s, std::int64_t frames, bool framesGiven, Uint32 length) {
  if (length == DCM_UndefinedLength) {
    return "the pixel data has an undefined length, which only compressed transfer syntaxes use";
  }
  const std::string tags = fmt::format("Rows {}, Columns {}, SamplesPerPixel {}{} BitsAllocated {}{}", s.rows,
                                       s.columns, s.samplesPerPixel, framesGiven ? "," : " and", s.bitsAllocated,
                                       framesGiven ? fmt::format(" and NumberOfFrames {}", frames) : std::string());
  std::uint64_t bits = 0;
  if (__builtin_mul_overflow(std::uint64_t{s.rows} * s.columns, std::uint64_t{s.samplesPerPixel} * s.bitsAllocated,
                             &bits) ||
      __builtin_mul_overflow(bits, static_cast<std::uint64_t>(frames), &bits)) {
    return fmt::format("the pixel data holds {} bytes, but {} need more than 2^64 bits", length, tags);
  }
  const std::uint64_t need = (bits + 7) / 8;
  if (length == need || (need % 2 == 1 && length == need + 1)) return {};
  // What would use every byte: twice the bits per sample, or another number of frames (in a file
  // that counts them) or of rows (in one that does not).
  std::vector<std::string> fits;
  if (s.bitsAllocated >= 8 && s.bitsAllocated <= 16 && length == 2 * need) {
    fits.push_back(fmt::format("BitsAllocated {}", 2 * s.bitsAllocated));
  }
  const std::uint64_t unitBits = framesGiven ? bits / static_cast<std::uint64_t>(frames) : bits / s.rows;
  if (unitBits % 8 == 0 && length % (unitBits / 8) == 0) {
    const std::uint64_t units = length / (unitBits / 8);
    if (units > 0 && units <= (framesGiven ? static_cast<std::uint64_t>(limits::kMaxFrames) : 0xffff)) {
      fits.push_back(fmt::format("{} {}", framesGiven ? "NumberOfFrames" : "Rows", units));
    }
  }
  const std::string hint = fits.empty()       ? std::string()
                           : fits.size() == 1 ? fmt::format("; {} would use them all", fits[0])
                                              : fmt::format("; {} or {} would use them all", fits[0], fits[1]);
  return fmt::format("the pixel data holds {} bytes, but {} need {}{}; the length and those tags disagree{}", length,
                     tags, need, need % 2 == 1 ? fmt::format(" (or {} padded)", need + 1) : std::string(), hint);
}

}  // namespace

namespace dicom {
std::string nestingDepthProblem(const std::string& path) {
  return nestingProblem(path);
}
}  // namespace dicom

DicomScan scanDicom(const std::vector<std::string>& inputs, const DicomOptions& options) {
  initDcmtk();
  DicomScan scan;
  // 1. The files, in a deterministic order.
  std::vector<std::string> files;
  for (const std::string& input : inputs) {
    std::error_code ec;
    if (fs::is_directory(input, ec)) {
      std::vector<std::string> found;
      for (fs::recursive_directory_iterator it(input, ec), end; it != end; it.increment(ec)) {
        if (ec) throw Error(fmt::format("{}: cannot read folder: {}", input, ec.message()));
        if (it->is_regular_file(ec)) found.push_back(it->path().string());
      }
      std::sort(found.begin(), found.end(),
                [](const std::string& a, const std::string& b) { return naturalLess(a, b); });
      files.insert(files.end(), found.begin(), found.end());
    } else if (fs::path(input).filename() == "DICOMDIR") {
      const auto listed = dicomdirFiles(input);
      files.insert(files.end(), listed.begin(), listed.end());
    } else if (fs::exists(input, ec)) {
      files.push_back(input);
    } else {
      throw Error(fmt::format("{}: cannot open: {}", input, std::strerror(ENOENT)));
    }
  }

  // 2. The header pass: headers only, large elements (pixel data) stay on disk.
  std::map<std::string, std::size_t> seriesIndex;
  std::vector<DicomSeries> series;
  std::map<std::string, std::vector<std::string>> filesOfSeries;
  for (const std::string& path : files) {
    // Files a DICOMDIR lists may be missing, or be FIFOs and devices (which would block or never end).
    if (std::error_code ec; !fs::is_regular_file(path, ec)) {
      const bool exists = fs::exists(path, ec);
      const std::string msg = exists ? fmt::format("{}: not a regular file (FIFOs and devices are not read)", path)
                                     : fmt::format("{}: cannot open: {}", path, std::strerror(ENOENT));
      if (!options.skipBad) throw Error(msg);
      scan.warnings.push_back(msg + " (skipped)");
      continue;
    }
    if (fs::path(path).filename() == "DICOMDIR" || !looksLikeDicom(path)) {
      ++scan.skipped;
      continue;
    }
    if (const std::string msg = nestingProblem(path); !msg.empty()) {
      if (!options.skipBad) throw Error(msg);
      scan.warnings.push_back(msg + " (skipped)");
      continue;
    }
    DcmFileFormat ff;
    const OFCondition c = ff.loadFile(path.c_str(), EXS_Unknown, EGL_noChange, 1024);
    if (c.bad()) {
      const std::string msg = fmt::format("{}: not a readable DICOM file: {}", path, c.text());
      if (!options.skipBad) throw Error(msg);
      scan.warnings.push_back(msg + " (skipped)");
      continue;
    }
    DcmDataset* ds = ff.getDataset();
    if (!ds->tagExists(DCM_PixelData) || getU16(ds, DCM_Rows) == 0 || getU16(ds, DCM_Columns) == 0) {
      ++scan.skipped;
      continue;
    }
    if (const std::string sop = getString(ds, DCM_SOPClassUID);
        sop == "1.2.840.10008.5.1.4.1.1.66.4" || sop == "1.2.840.10008.5.1.4.1.1.66.7") {
      scan.segmentations.push_back(path);
      ++scan.skipped;
      continue;
    }
    DicomSeries s;
    s.uid = getString(ds, DCM_SeriesInstanceUID);
    if (s.uid.empty()) s.uid = "(no SeriesInstanceUID)";
    s.description = getString(ds, DCM_SeriesDescription);
    s.modality = getString(ds, DCM_Modality);
    const DcmXfer xfer(ds->getOriginalXfer());
    s.transferSyntax = xfer.getXferName();
    s.transferSyntaxUid = xfer.getXferID();
    s.rows = getU16(ds, DCM_Rows);
    s.columns = getU16(ds, DCM_Columns);
    s.bitsAllocated = getU16(ds, DCM_BitsAllocated, 16);
    s.bitsStored = getU16(ds, DCM_BitsStored, s.bitsAllocated);
    s.highBit = getU16(ds, DCM_HighBit, static_cast<std::uint16_t>(std::max(1, int{s.bitsStored}) - 1));
    s.pixelRepresentation = getU16(ds, DCM_PixelRepresentation);
    s.samplesPerPixel = getU16(ds, DCM_SamplesPerPixel, 1);
    s.planarConfiguration = getU16(ds, DCM_PlanarConfiguration);
    s.photometric = getString(ds, DCM_PhotometricInterpretation);
    if (double tilt = 0; getDoubles(ds, DCM_GantryDetectorTilt, &tilt, 1)) s.gantryTilt = tilt;
    if (const std::string problem = pixelModuleProblem(s.bitsAllocated, s.bitsStored, s.highBit, s.samplesPerPixel);
        !problem.empty()) {
      const std::string msg = fmt::format("{}: {}", path, problem);
      if (!options.skipBad) throw Error(msg);
      scan.warnings.push_back(msg + " (skipped)");
      continue;
    }
    Sint32 frames = 1;
    if (ds->findAndGetSint32(DCM_NumberOfFrames, frames).bad() || frames < 1) frames = 1;
    {
      // Each frame takes its pixels (or, compressed, at least an 8-byte fragment header) in the file.
      std::error_code sizeError;
      const auto fileBytes = static_cast<std::int64_t>(fs::file_size(path, sizeError));
      const std::int64_t frameBytes =
          xfer.isEncapsulated() ? 8
                                : std::max<std::int64_t>(1, std::int64_t{s.rows} * s.columns * s.samplesPerPixel *
                                                                ((s.bitsAllocated + 7) / 8));
      if (frames > limits::kMaxFrames || (!sizeError && frames > 1 && frames > fileBytes / frameBytes)) {
        const std::string msg =
            frames > limits::kMaxFrames
                ? fmt::format("{}: NumberOfFrames {} exceeds the limit of {} frames", path, frames, limits::kMaxFrames)
                : fmt::format("{}: NumberOfFrames {} is more than the file's {} bytes hold", path, frames, fileBytes);
        if (!options.skipBad) throw Error(msg);
        scan.warnings.push_back(msg + " (skipped)");
        continue;
      }
    }
    // Uncompressed pixel data (deflate compresses the dataset, not the pixels) must be as long as
    // the pixel module says; encapsulated fragments are checked as they are decoded.
    if (DcmElement* pixelData = nullptr;
        !xfer.isEncapsulated() && ds->findAndGetElement(DCM_PixelData, pixelData).good() && pixelData != nullptr) {
      if (const std::string problem =
              pixelDataLengthProblem(s, frames, ds->tagExists(DCM_NumberOfFrames), pixelData->getLengthField());
          !problem.empty()) {
        const std::string msg = fmt::format("{}: {}", path, problem);
        if (!options.skipBad) throw Error(msg);
        scan.warnings.push_back(msg + " (skipped)");
        continue;
      }
    }
    DcmItem* shared = subItem(ds, DCM_SharedFunctionalGroupsSequence);
    s.multiFrame = frames > 1 || shared != nullptr;
    Sint32 instance = 0;
    ds->findAndGetSint32(DCM_InstanceNumber, instance);
    // Frames by stack (FrameContentSequence > StackID): a file with several stacks becomes one
    // series per stack, "<SeriesInstanceUID>/stack <id>".
    std::map<std::string, DicomSeries> stacks;
    for (Sint32 f = 0; f < frames; ++f) {
      DcmItem* perFrame = nullptr;
      if (s.multiFrame) ds->findAndGetSequenceItem(DCM_PerFrameFunctionalGroupsSequence, perFrame, f);
      // Non-finite geometry would sort, space and place slices nowhere (and never end a gap walk):
      // frameGeometry refuses it, with text, zero spacing and degenerate orientations.
      const FrameGeometry g = frameGeometry(s.multiFrame ? nullptr : ds, perFrame, shared, path);
      const std::string stack = getString(subItem(perFrame, DCM_FrameContentSequence), DCM_StackID);
      auto [entry, first] = stacks.try_emplace(stack, s);
      DicomSeries& into = entry->second;
      if (first) {
        if (g.orientation) into.orientation = *g.orientation;
        if (g.spacing) into.pixelSpacing = *g.spacing;
      } else {
        if (g.orientation && !sameOrientation(*g.orientation, into.orientation)) {
          throw Error(
              fmt::format("{}: frames of one stack have different orientations; "
                          "choose a single-orientation export of this series",
                          path));
        }
        if (g.spacing && !sameSpacing(*g.spacing, into.pixelSpacing)) {
          throw Error(fmt::format("{}: frame {} has PixelSpacing {:g}\\{:g} but frame 1 has {:g}\\{:g}", path, f + 1,
                                  (*g.spacing)[0], (*g.spacing)[1], into.pixelSpacing[0], into.pixelSpacing[1]));
        }
      }
      DicomSlice slice;
      slice.path = path;
      slice.frame = static_cast<std::uint32_t>(f);
      slice.position = g.position;
      slice.instanceNumber = s.multiFrame ? f + 1 : instance;
      slice.slope = g.slope;
      slice.intercept = g.intercept;
      if (g.thickness && *g.thickness > 0 && std::isfinite(*g.thickness)) slice.thickness = g.thickness;
      into.slices.push_back(slice);
    }
    if (stacks.size() > 1) {
      for (auto& [id, stack] : stacks) {
        stack.uid = fmt::format("{}/stack {}", s.uid, id);
        seriesIndex.emplace(stack.uid, series.size());
        series.push_back(std::move(stack));
      }
      continue;
    }
    s = std::move(stacks.begin()->second);
    auto [it, added] = seriesIndex.emplace(s.uid, series.size());
    if (added) {
      series.push_back(std::move(s));
      continue;
    }
    // 3. Consistency within a series.
    DicomSeries& into = series[it->second];
    const std::string& first = into.slices.front().path;
    if (s.rows != into.rows || s.columns != into.columns) {
      throw Error(fmt::format("{}: {} has {}x{} pixels but {} has {}x{} (mixed sizes in one series)", seriesLabel(into),
                              path, s.columns, s.rows, first, into.columns, into.rows));
    }
    if (!sameOrientation(s.orientation, into.orientation)) {
      throw Error(fmt::format("{}: {} and {} have different ImageOrientationPatient (mixed orientations in one series)",
                              seriesLabel(into), path, first));
    }
    // Every image must agree with the first, so all agree with each other: the volume has one
    // pixel type and one in-plane spacing.
    auto differs = [&](const char* what, const auto& mine, const auto& theirs) {
      if (mine == theirs) return;
      throw Error(fmt::format("{}: {} has {} {} but {} has {} (mixed pixel types in one series)", seriesLabel(into),
                              path, what, mine, first, theirs));
    };
    differs("SamplesPerPixel", s.samplesPerPixel, into.samplesPerPixel);
    differs("BitsAllocated", s.bitsAllocated, into.bitsAllocated);
    differs("BitsStored", s.bitsStored, into.bitsStored);
    differs("HighBit", s.highBit, into.highBit);
    differs("PixelRepresentation", s.pixelRepresentation, into.pixelRepresentation);
    differs("PhotometricInterpretation", s.photometric.empty() ? std::string("(none)") : s.photometric,
            into.photometric.empty() ? std::string("(none)") : into.photometric);
    if (!sameSpacing(s.pixelSpacing, into.pixelSpacing)) {
      throw Error(fmt::format("{}: {} has PixelSpacing {:g}\\{:g} but {} has {:g}\\{:g} (mixed spacings in one series)",
                              seriesLabel(into), path, s.pixelSpacing[0], s.pixelSpacing[1], first,
                              into.pixelSpacing[0], into.pixelSpacing[1]));
    }
    into.slices.insert(into.slices.end(), s.slices.begin(), s.slices.end());
  }

  // 4. Sort each series, drop duplicates, find gaps.
  for (DicomSeries& s : series) {
    const Vec3d row{s.orientation[0], s.orientation[1], s.orientation[2]};
    const Vec3d col{s.orientation[3], s.orientation[4], s.orientation[5]};
    const Vec3d normal = cross(row, col);
    const bool positioned =
        std::all_of(s.slices.begin(), s.slices.end(), [](const DicomSlice& d) { return d.position.has_value(); });
    if (!positioned) {
      // Some slices placed and some not cannot be sorted or spaced: neither order is right.
      const auto with = std::find_if(s.slices.begin(), s.slices.end(), [](const DicomSlice& d) { return d.position; });
      if (with != s.slices.end()) {
        const auto without =
            std::find_if(s.slices.begin(), s.slices.end(), [](const DicomSlice& d) { return !d.position; });
        const auto frameOf = [&](const DicomSlice& d) {
          return s.multiFrame ? fmt::format(" frame {}", d.frame + 1) : std::string();
        };
        throw Error(fmt::format("{}: {}{} has no ImagePositionPatient, but {}{} has one", seriesLabel(s), without->path,
                                frameOf(*without), with->path, frameOf(*with)));
      }
    }
    auto key = [&](const DicomSlice& d) {
      return positioned ? dot(*d.position, normal) : static_cast<double>(d.instanceNumber);
    };
    std::stable_sort(s.slices.begin(), s.slices.end(), [&](const DicomSlice& a, const DicomSlice& b) {
      const double ka = key(a), kb = key(b);
      if (ka != kb) return ka < kb;
      if (a.instanceNumber != b.instanceNumber) return a.instanceNumber < b.instanceNumber;
      return a.path != b.path ? naturalLess(a.path, b.path) : a.frame < b.frame;
    });
    if (!positioned) {
      s.warnings.push_back(
          "ImagePositionPatient is missing; slices are sorted by InstanceNumber and spaced 1 mm apart");
    }
    std::vector<DicomSlice> kept;
    for (const DicomSlice& d : s.slices) {
      if (!kept.empty() && std::abs(key(d) - key(kept.back())) < (positioned ? 1e-3 : 0.5)) {
        s.warnings.push_back(fmt::format("duplicate position: {} dropped, {} kept", d.path, kept.back().path));
        continue;
      }
      kept.push_back(d);
    }
    s.slices = std::move(kept);
    if (positioned) {
      for (std::size_t k = 1; k < s.slices.size(); ++k) s.gaps.push_back(key(s.slices[k]) - key(s.slices[k - 1]));
      if (!s.gaps.empty()) {
        std::vector<double> sorted = s.gaps;
        std::sort(sorted.begin(), sorted.end());
        const double median = sorted[sorted.size() / 2];
        // A gap over 1.5 times the median spacing is a missing slice unless the slices on either side
        // are thick enough to meet across it (half of each one's SliceThickness): series that change
        // their slice thickness part-way, like the GE tilt series (4 mm, then 7 mm), space their
        // slices by it. One message per run of consecutive large gaps of the same kind: a warning
        // when a slice may be missing, a note when the thickness covers the gaps.
        enum class GapKind { kEven, kCovered, kMissing };
        auto pairThickness = [&](std::size_t k) -> std::optional<double> {
          const auto& a = s.slices[k].thickness;
          const auto& b = s.slices[k + 1].thickness;
          if (!a || !b) return std::nullopt;
          return (*a + *b) / 2;
        };
        auto kindOf = [&](std::size_t k) {
          if (s.gaps[k] <= 1.5 * median) return GapKind::kEven;
          const auto t = pairThickness(k);
          return t && s.gaps[k] <= *t + thicknessTolerance(*t) ? GapKind::kCovered : GapKind::kMissing;
        };
        auto range = [](double lo, double hi) {
          const std::string a = fmt::format("{:.3g}", lo);
          const std::string b = fmt::format("{:.3g}", hi);
          return a == b ? a : fmt::format("{} to {}", a, b);
        };
        for (std::size_t k = 0; k < s.gaps.size();) {
          const GapKind kind = kindOf(k);
          if (kind == GapKind::kEven) {
            ++k;
            continue;
          }
          std::size_t end = k;
          double narrowest = s.gaps[k], widest = s.gaps[k];
          bool equal = true;  // every gap equals its slices' thickness (rather than being below it)
          while (end < s.gaps.size() && kindOf(end) == kind) {
            narrowest = std::min(narrowest, s.gaps[end]);
            widest = std::max(widest, s.gaps[end]);
            if (kind == GapKind::kCovered) {
              const double t = *pairThickness(end);
              equal = equal && std::abs(s.gaps[end] - t) <= thicknessTolerance(t);
            }
            ++end;
          }
          // SliceThickness of the slices around the run, when every one of them has it.
          std::optional<std::array<double, 2>> thick = std::array<double, 2>{kInf, -kInf};
          for (std::size_t n = k; n <= end && thick; ++n) {
            const auto& t = s.slices[n].thickness;
            thick = t ? std::optional(std::array<double, 2>{std::min((*thick)[0], *t), std::max((*thick)[1], *t)})
                      : std::nullopt;
          }
          const std::size_t count = end - k;
          const bool one = count == 1;
          const std::string where =
              one ? fmt::format("gap of {:.3g} mm between {} and {}", widest, s.slices[k].path, s.slices[k + 1].path)
                  : fmt::format("{} gaps of {} mm from {} to {}", count, range(narrowest, widest), s.slices[k].path,
                                s.slices[end].path);
          if (kind == GapKind::kCovered) {
            const char* verb = equal ? (one ? "equals" : "equal") : (one ? "is within" : "are within");
            s.notes.push_back(fmt::format(
                "uneven slice spacing: {}{} (median spacing {:.3g} mm) {} the slice thickness ({} mm): no slice is "
                "missing",
                one ? "a " : "", where, median, verb, range((*thick)[0], (*thick)[1])));
          } else {
            const std::string thickness =
                thick ? fmt::format(", slice thickness {} mm", range((*thick)[0], (*thick)[1])) : std::string();
            s.warnings.push_back(fmt::format("{} (median spacing {:.3g} mm{}): {}", where, median, thickness,
                                             one ? "a slice may be missing" : "slices may be missing"));
          }
          k = end;
        }
      }
    }
    if (options.strict && !s.warnings.empty()) {
      throw Error(fmt::format("{}: {} (`strict`)", seriesLabel(s), s.warnings.front()));
    }
  }
  scan.series = std::move(series);
  return scan;
}

namespace {

// OpenJPEG reads the codestream from memory.
struct MemoryStream {
  const std::uint8_t* data;
  std::size_t size;
  std::size_t pos;
};

OPJ_SIZE_T j2kRead(void* buffer, OPJ_SIZE_T n, void* user) {
  auto* m = static_cast<MemoryStream*>(user);
  if (m->pos >= m->size) return static_cast<OPJ_SIZE_T>(-1);
  const std::size_t k = std::min<std::size_t>(n, m->size - m->pos);
  std::memcpy(buffer, m->data + m->pos, k);
  m->pos += k;
  return k;
}
OPJ_OFF_T j2kSkip(OPJ_OFF_T n, void* user) {
  auto* m = static_cast<MemoryStream*>(user);
  const auto target = static_cast<OPJ_OFF_T>(m->pos) + n;
  if (target < 0) return -1;
  m->pos = static_cast<std::size_t>(std::min<OPJ_OFF_T>(target, static_cast<OPJ_OFF_T>(m->size)));
  return n;
}
OPJ_BOOL j2kSeek(OPJ_OFF_T n, void* user) {
  auto* m = static_cast<MemoryStream*>(user);
  if (n < 0 || static_cast<std::size_t>(n) > m->size) return OPJ_FALSE;
  m->pos = static_cast<std::size_t>(n);
  return OPJ_TRUE;
}

// Owners of OpenJPEG's handles.
struct OpjCodecDeleter {
  void operator()(opj_codec_t* codec) const noexcept { opj_destroy_codec(codec); }
};
struct OpjStreamDeleter {
  void operator()(opj_stream_t* stream) const noexcept { opj_stream_destroy(stream); }
};
struct OpjImageDeleter {
  void operator()(opj_image_t* image) const noexcept { opj_image_destroy(image); }
};
using OpjCodec = std::unique_ptr<opj_codec_t, OpjCodecDeleter>;
using OpjStream = std::unique_ptr<opj_stream_t, OpjStreamDeleter>;
using OpjImage = std::unique_ptr<opj_image_t, OpjImageDeleter>;

// Decodes one JPEG 2000 frame into 32-bit samples, component `channel`.
std::vector<std::int32_t> decodeJpeg2000(const std::string& path, const std::vector<std::uint8_t>& code, int channel,
                                         std::uint32_t columns, std::uint32_t rows) {
  const bool jp2 = code.size() > 12 && code[4] == 'j' && code[5] == 'P';
  // Declared in this order, the handles are released image first, then stream, then codec.
  const OpjCodec codec(opj_create_decompress(jp2 ? OPJ_CODEC_JP2 : OPJ_CODEC_J2K));
  opj_dparameters_t params;
  opj_set_default_decoder_parameters(&params);
  opj_setup_decoder(codec.get(), &params);
  MemoryStream mem{code.data(), code.size(), 0};
  const OpjStream stream(opj_stream_default_create(OPJ_TRUE));
  opj_stream_set_user_data(stream.get(), &mem, nullptr);
  opj_stream_set_user_data_length(stream.get(), code.size());
  opj_stream_set_read_function(stream.get(), j2kRead);
  opj_stream_set_skip_function(stream.get(), j2kSkip);
  opj_stream_set_seek_function(stream.get(), j2kSeek);
  opj_image_t* header = nullptr;
  const bool headerRead = opj_read_header(stream.get(), codec.get(), &header);
  const OpjImage image(header);
  const bool ok =
      headerRead && opj_decode(codec.get(), stream.get(), image.get()) && opj_end_decompress(codec.get(), stream.get());
  std::vector<std::int32_t> out;
  std::string problem;
  if (!ok || image == nullptr) {
    problem = "the JPEG 2000 data cannot be decoded";
  } else if (static_cast<std::uint32_t>(channel) >= image->numcomps) {
    problem = fmt::format("the JPEG 2000 frame has {} components", image->numcomps);
  } else {
    const opj_image_comp_t& comp = image->comps[channel];
    if (comp.w != columns || comp.h != rows) {
      problem = fmt::format("the JPEG 2000 frame is {}x{} but the header says {}x{}", comp.w, comp.h, columns, rows);
    } else {
      out.assign(comp.data, comp.data + static_cast<std::size_t>(columns) * rows);
    }
  }
  if (!problem.empty()) throw Error(fmt::format("{}: {}", path, problem));
  return out;
}

bool supportedTransferSyntax(E_TransferSyntax x) {
  switch (x) {
    case EXS_LittleEndianImplicit:
    case EXS_LittleEndianExplicit:
    case EXS_BigEndianExplicit:
    case EXS_DeflatedLittleEndianExplicit:
    case EXS_RLELossless:
    case EXS_JPEGProcess1:
    case EXS_JPEGProcess2_4:
    case EXS_JPEGProcess14:
    case EXS_JPEGProcess14SV1:
    case EXS_JPEGLSLossless:
    case EXS_JPEGLSLossy:
    case EXS_JPEG2000LosslessOnly:
    case EXS_JPEG2000:
    case EXS_JPEG2000MulticomponentLosslessOnly:
    case EXS_JPEG2000Multicomponent:
      return true;
    default:
      return false;
  }
}

class DicomSource final : public SliceSource {
 public:
  DicomSource(const DicomSeries& series, const DicomOptions& options) : series_(series), options_(options) {
    const std::string first = series.slices.front().path;
    if (series.slices.size() < 2) {
      throw Error(fmt::format("{}: {} has one image; a surface needs at least two slices", first, seriesLabel(series)));
    }
    if (series.samplesPerPixel > 1) {
      if (options.channel < 0) {
        throw Error(fmt::format("{}: colour images ({}, {} samples per pixel); choose a channel with `channel` 0..{}",
                                first, series.photometric, series.samplesPerPixel, series.samplesPerPixel - 1));
      }
    }
    // Also for grey images: a channel past the samples would index past every pixel's.
    if (options.channel >= series.samplesPerPixel) {
      throw Error(fmt::format("`channel`: {} has {} sample{} per pixel", first, series.samplesPerPixel,
                              series.samplesPerPixel == 1 ? "" : "s"));
    }
    if (series.bitsAllocated != 8 && series.bitsAllocated != 16 && series.bitsAllocated != 32) {
      throw Error(fmt::format("{}: BitsAllocated {} is not supported (8, 16 or 32)", first, series.bitsAllocated));
    }
    if (const std::string problem =
            pixelModuleProblem(series.bitsAllocated, series.bitsStored, series.highBit, series.samplesPerPixel);
        !problem.empty()) {
      throw Error(fmt::format("{}: {}", first, problem));
    }
    // Positions are used for every slice or for none (the scan refuses a series that mixes them).
    for (const DicomSlice& s : series.slices) {
      if (s.position.has_value() != series.slices.front().position.has_value()) {
        throw Error(fmt::format("{}: ImagePositionPatient is {}, but {} {}", s.path, s.position ? "present" : "missing",
                                first, s.position ? "lacks it" : "has it"));
      }
    }
    const auto& o = series.orientation;
    const Vec3d row{o[0], o[1], o[2]};
    const Vec3d col{o[3], o[4], o[5]};
    const Vec3d normal = cross(row, col);
    VolumeInfo& info = info_;
    info.dims = {series.columns, series.rows, static_cast<std::int64_t>(series.slices.size())};
    validateDims(info.dims, first);  // a 1-pixel-wide image has no cell, as in every other reader
    info.reader = "dicom";
    info.source = first;
    info.frame = "lps";
    info.modality = series.modality;
    const bool positioned = series.slices.front().position.has_value();
    Vec3d kdir = normal;
    double kspacing = 1;
    if (positioned) {
      const Vec3d& a = *series.slices.front().position;
      const Vec3d& b = *series.slices.back().position;
      const Vec3d d{b[0] - a[0], b[1] - a[1], b[2] - a[2]};
      const double len = norm(d);
      if (len > 0) {
        kdir = {d[0] / len, d[1] / len, d[2] / len};
        kspacing = len / static_cast<double>(series.slices.size() - 1);
      }
      for (const DicomSlice& s : series.slices) info.sliceOrigins.push_back(*s.position);
      info.origin = a;
    } else {
      for (std::size_t k = 0; k < series.slices.size(); ++k) {
        info.sliceOrigins.push_back({normal[0] * static_cast<double>(k), normal[1] * static_cast<double>(k),
                                     normal[2] * static_cast<double>(k)});
      }
    }
    info.spacing = {series.pixelSpacing[1], series.pixelSpacing[0], kspacing};
    info.spacingFields = {"PixelSpacing", "PixelSpacing", positioned ? "ImagePositionPatient" : "slice spacing"};
    info.originField = "ImagePositionPatient";
    info.direction = {row[0], col[0], kdir[0], row[1], col[1], kdir[1], row[2], col[2], kdir[2]};
    const bool sign = series.pixelRepresentation == 1;
    info.type = series.bitsAllocated == 8    ? (sign ? VoxelType::kI8 : VoxelType::kU8)
                : series.bitsAllocated == 16 ? (sign ? VoxelType::kI16 : VoxelType::kU16)
                                             : (sign ? VoxelType::kI32 : VoxelType::kU32);
  }

  const VolumeInfo& info() const noexcept override { return info_; }

  // A skipped slice's file is not opened and its pixel data is not read. The one exception are
  // frames of a compressed multi-frame file that the next slice read comes from: they are decoded
  // and dropped, so that DCMTK can count on to the next frame's first fragment (startFragment_)
  // even where the file has no offset table and frames of several fragments.
  std::int64_t skipSlices(std::int64_t n) override {
    const std::size_t end = next_ + static_cast<std::size_t>(std::clamp<std::int64_t>(
                                        n, 0, static_cast<std::int64_t>(series_.slices.size() - next_)));
    const bool chained = series_.multiFrame && DcmXfer(series_.transferSyntaxUid.c_str()).isEncapsulated();
    const std::string* following = chained && end < series_.slices.size() ? &series_.slices[end].path : nullptr;
    std::vector<float> scratch;
    const auto skipped = static_cast<std::int64_t>(end - next_);
    while (next_ < end) {
      if (following != nullptr && series_.slices[next_].path == *following) {
        scratch.resize(static_cast<std::size_t>(info_.sliceVoxels()));
        readSlice(scratch);
      } else {
        ++next_;
      }
    }
    return skipped;
  }

  bool readSlice(std::span<float> out) override {
    if (next_ >= series_.slices.size()) return false;
    const DicomSlice& slice = series_.slices[next_++];
    if (slice.path != openPath_) {
      file_ = std::make_unique<DcmFileFormat>();
      cache_ = std::make_unique<DcmFileCache>();
      const OFCondition c = file_->loadFile(slice.path.c_str(), EXS_Unknown, EGL_noChange, 4096);
      if (c.bad()) throw Error(fmt::format("{}: not a readable DICOM file: {}", slice.path, c.text()));
      openPath_ = slice.path;
      startFragment_ = 0;
      nextFrame_ = 0;
    }
    // DCMTK leaves startFragment_ at the fragment after the frame it decoded: a valid hint for the
    // next frame only. For any other (frames sorted out of file order, or skipped), 0 lets DCMTK
    // find the frame's fragment itself, from the offset table or one fragment per frame.
    if (slice.frame != nextFrame_) startFragment_ = 0;
    nextFrame_ = slice.frame + 1;
    DcmDataset* ds = file_->getDataset();
    const std::uint16_t rows = getU16(ds, DCM_Rows);
    const std::uint16_t columns = getU16(ds, DCM_Columns);
    if (rows != series_.rows || columns != series_.columns) {
      throw Error(fmt::format("{}: the image is {}x{} but the series is {}x{}", slice.path, columns, rows,
                              series_.columns, series_.rows));
    }
    const std::uint16_t bitsAllocated = getU16(ds, DCM_BitsAllocated, 16);
    const std::uint16_t bitsStored = getU16(ds, DCM_BitsStored, bitsAllocated);
    const bool sign = getU16(ds, DCM_PixelRepresentation) == 1;
    const std::uint16_t spp = getU16(ds, DCM_SamplesPerPixel, 1);
    const std::uint16_t highBit = getU16(ds, DCM_HighBit, static_cast<std::uint16_t>(std::max(1, int{bitsStored}) - 1));
    // The masks and shifts below take BitsStored as it is: check it first (the file may also have
    // changed since the scan).
    if (const std::string problem = pixelModuleProblem(bitsAllocated, bitsStored, highBit, spp); !problem.empty()) {
      throw Error(fmt::format("{}: {}", slice.path, problem));
    }
    if (bitsAllocated != series_.bitsAllocated || bitsStored != series_.bitsStored || spp != series_.samplesPerPixel ||
        sign != (series_.pixelRepresentation == 1)) {
      throw Error(
          fmt::format("{}: BitsAllocated {}, BitsStored {}, PixelRepresentation {} and SamplesPerPixel {} "
                      "differ from the series' {}, {}, {} and {}",
                      slice.path, bitsAllocated, bitsStored, sign ? 1 : 0, spp, series_.bitsAllocated,
                      series_.bitsStored, series_.pixelRepresentation, series_.samplesPerPixel));
    }
    const bool planar = getU16(ds, DCM_PlanarConfiguration) == 1;
    const bool mono1 = getString(ds, DCM_PhotometricInterpretation) == "MONOCHROME1";
    const std::size_t pixels = static_cast<std::size_t>(rows) * columns;
    const int channel = std::max(0, options_.channel);

    // Kept from slice to slice: a fresh 2 MB array a slice was mapped, faulted in and zeroed each
    // time (a fifth of the page faults of a run on the Philips head). Every path below writes all
    // of its first `pixels` entries.
    std::vector<std::int64_t>& samples = samples_;
    samples.resize(pixels);
    const E_TransferSyntax xfer = ds->getOriginalXfer();
    if (!supportedTransferSyntax(xfer)) {
      throw Error(fmt::format("{}: unsupported transfer syntax '{}' ({})", slice.path, DcmXfer(xfer).getXferName(),
                              DcmXfer(xfer).getXferID()));
    }
    if (xfer == EXS_JPEG2000LosslessOnly || xfer == EXS_JPEG2000 || xfer == EXS_JPEG2000MulticomponentLosslessOnly ||
        xfer == EXS_JPEG2000Multicomponent) {
      const auto decoded = decodeJpeg2000(slice.path, jpeg2000Frame(ds, slice), channel, columns, rows);
      const std::size_t n = std::min(decoded.size(), pixels);
      std::copy(decoded.begin(), decoded.begin() + static_cast<std::ptrdiff_t>(n), samples.begin());
      std::fill(samples.begin() + static_cast<std::ptrdiff_t>(n), samples.end(), 0);
    } else {
      DcmElement* pixelData = nullptr;
      if (ds->findAndGetElement(DCM_PixelData, pixelData).bad() || pixelData == nullptr) {
        throw Error(fmt::format("{}: has no pixel data", slice.path));
      }
      Uint32 frameSize = 0;
      if (pixelData->getUncompressedFrameSize(ds, frameSize).bad()) {
        throw Error(fmt::format("{}: cannot determine the frame size", slice.path));
      }
      const std::size_t bytesPerSample = bitsAllocated / 8u;
      if (frameSize < pixels * spp * bytesPerSample) {
        throw Error(
            fmt::format("{}: frame of {} bytes is shorter than {}x{} pixels", slice.path, frameSize, columns, rows));
      }
      if (!DcmXfer(xfer).isEncapsulated()) {
        const std::uint64_t need = std::uint64_t{frameSize} * (slice.frame + 1);
        if (pixelData->getLength() < need) {
          throw Error(fmt::format("{}: the pixel data holds {} bytes, but {}x{} pixels of {} bits{} need {}",
                                  slice.path, pixelData->getLength(), columns, rows, bitsAllocated,
                                  slice.frame > 0 ? fmt::format(" up to frame {}", slice.frame + 1) : std::string(),
                                  need));
        }
      }
      frameBytes_.resize(frameSize + (frameSize & 1u));
      OFString colorModel;
      const OFCondition c =
          pixelData->getUncompressedFrame(ds, slice.frame, startFragment_, frameBytes_.data(),
                                          static_cast<Uint32>(frameBytes_.size()), colorModel, cache_.get());
      if (c.bad()) {
        if (c == EC_CannotChangeRepresentation || DcmXfer(xfer).isEncapsulated()) {
          throw Error(fmt::format("{}: transfer syntax '{}' ({}) cannot be decoded: {}", slice.path,
                                  DcmXfer(xfer).getXferName(), DcmXfer(xfer).getXferID(), c.text()));
        }
        throw Error(fmt::format("{}: cannot read frame {}: {}", slice.path, slice.frame, c.text()));
      }
      for (std::size_t p = 0; p < pixels; ++p) {
        const std::size_t index =
            planar ? static_cast<std::size_t>(channel) * pixels + p : p * spp + static_cast<std::size_t>(channel);
        const std::uint8_t* b = frameBytes_.data() + index * bytesPerSample;
        std::uint32_t raw = 0;
        if (bytesPerSample == 1) {
          raw = b[0];
        } else if (bytesPerSample == 2) {
          std::uint16_t v;
          std::memcpy(&v, b, 2);
          raw = v;
        } else {
          std::memcpy(&raw, b, 4);
        }
        std::int64_t v = raw;
        if (bitsStored < 32) {
          const std::uint32_t mask = (1u << bitsStored) - 1u;
          v = raw & mask;
          if (sign && (raw & (1u << (bitsStored - 1)))) v -= std::int64_t{1} << bitsStored;
        } else if (sign) {
          v = static_cast<std::int32_t>(raw);
        }
        samples[p] = v;
      }
    }
    // MONOCHROME1 stores darker-is-higher: invert within the stored range.
    std::int64_t lo = sign ? -(std::int64_t{1} << (bitsStored - 1)) : 0;
    std::int64_t hi = sign ? (std::int64_t{1} << (bitsStored - 1)) - 1 : (std::int64_t{1} << bitsStored) - 1;
    for (std::size_t p = 0; p < pixels; ++p) {
      const std::int64_t v = mono1 ? lo + hi - samples[p] : samples[p];
      out[p] = static_cast<float>(static_cast<double>(v) * slice.slope + slice.intercept);
    }
    return true;
  }

 private:
  // The compressed bytes of one frame from the encapsulated pixel data.
  std::vector<std::uint8_t> jpeg2000Frame(DcmDataset* ds, const DicomSlice& slice) {
    DcmElement* element = nullptr;
    if (ds->findAndGetElement(DCM_PixelData, element).bad() || element == nullptr) {
      throw Error(fmt::format("{}: has no pixel data", slice.path));
    }
    auto* pixelData = static_cast<DcmPixelData*>(element);
    DcmPixelSequence* sequence = nullptr;
    if (pixelData->getEncapsulatedRepresentation(ds->getOriginalXfer(), nullptr, sequence).bad() ||
        sequence == nullptr) {
      throw Error(fmt::format("{}: the JPEG 2000 pixel data is not encapsulated", slice.path));
    }
    const unsigned long fragments = sequence->card() - 1;  // item 0 is the offset table
    Sint32 frames = 1;
    ds->findAndGetSint32(DCM_NumberOfFrames, frames);
    unsigned long first = 1;
    unsigned long last = fragments;
    if (frames > 1) {
      if (fragments != static_cast<unsigned long>(frames)) {
        throw Error(fmt::format("{}: multi-frame JPEG 2000 needs one fragment per frame ({} fragments, {} frames)",
                                slice.path, fragments, frames));
      }
      first = last = slice.frame + 1;
    }
    std::vector<std::uint8_t> code;
    for (unsigned long i = first; i <= last; ++i) {
      DcmPixelItem* item = nullptr;
      Uint8* data = nullptr;
      if (sequence->getItem(item, i).bad() || item->getUint8Array(data).bad()) {
        throw Error(fmt::format("{}: cannot read JPEG 2000 fragment {}", slice.path, i));
      }
      code.insert(code.end(), data, data + item->getLength());
      item->compact();
    }
    return code;
  }

  DicomSeries series_;
  DicomOptions options_;
  VolumeInfo info_;
  std::size_t next_ = 0;
  std::unique_ptr<DcmFileFormat> file_;
  std::unique_ptr<DcmFileCache> cache_;
  std::string openPath_;
  Uint32 startFragment_ = 0;
  std::uint32_t nextFrame_ = 0;  // the frame that startFragment_ is the hint for
  std::vector<std::int64_t> samples_;
  std::vector<std::uint8_t> frameBytes_;
};

}  // namespace

std::unique_ptr<SliceSource> openDicomSeries(const DicomSeries& series, const DicomOptions& options) {
  initDcmtk();
  return std::make_unique<DicomSource>(series, options);
}

}  // namespace isoslab
