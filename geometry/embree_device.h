// One way to create an Embree device: with an error callback that prints every error with its
// code and message (Embree's own text), and a clear exception when no device can be made.
// Include only from .cpp files that already use Embree (it pulls in embree3/rtcore.h).
#pragma once
#include <embree3/rtcore.h>

#include <cstdio>
#include <string>

#include "core/error.h"

namespace aniso {

inline const char* embree_error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "RTC_ERROR_NONE";
    case RTC_ERROR_UNKNOWN:
      return "RTC_ERROR_UNKNOWN";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "RTC_ERROR_INVALID_ARGUMENT";
    case RTC_ERROR_INVALID_OPERATION:
      return "RTC_ERROR_INVALID_OPERATION";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "RTC_ERROR_OUT_OF_MEMORY";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "RTC_ERROR_UNSUPPORTED_CPU";
    case RTC_ERROR_CANCELLED:
      return "RTC_ERROR_CANCELLED";
  }
  return "RTC_ERROR_?";
}

inline void embree_print_error(void* who, RTCError code, const char* message) {
  std::fprintf(stderr, "aniso: Embree error in %s: %s (%d): %s\n",
               who ? static_cast<const char*>(who) : "aniso", embree_error_name(code),
               static_cast<int>(code), message ? message : "(no message)");
}

// `who` names the user in messages (a string literal: it must outlive the device).
inline RTCDevice new_embree_device(const char* who) {
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) {
    const RTCError e = rtcGetDeviceError(nullptr);
    throw Error(std::string(who) + ": cannot create an Embree device: " + embree_error_name(e) +
                " (" + std::to_string(static_cast<int>(e)) + ")");
  }
  rtcSetDeviceErrorFunction(device, embree_print_error, const_cast<char*>(who));
  return device;
}

}  // namespace aniso
