// Error types shared by every cpgmatch component.
//
// InputError is for mistakes in what a user gave us (a config file, a flag, a DDS sample): the message
// names the field and, for files, the file and line. Executables turn it into exit code 2. Programmer
// errors are not InputError; they are assertions or std::logic_error.
#pragma once

#include <iostream>
#include <stdexcept>
#include <string>

#include "cpgmatch/text.hpp"

namespace cpgmatch {

class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Exit codes used by every cpgmatch executable.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitBadInput = 2;

// Runs an executable's body and turns what escapes it into the exit codes above, with "error: ..." on
// stderr: InputError -> 2, anything else -> 1. The message may echo input (a flag, a file's key): it is printed
// through escape_message_lines (text.hpp), as every cpgmatch executable prints its errors.
template <class Body>
int run_reporting_errors(Body&& body) {
  try {
    return body();
  } catch (const InputError& e) {
    std::cerr << "error: " << escape_message_lines(e.what()) << std::endl;
    return kExitBadInput;
  } catch (const std::exception& e) {
    std::cerr << "error: " << escape_message_lines(e.what()) << std::endl;
    return kExitFailure;
  }
}

}  // namespace cpgmatch
