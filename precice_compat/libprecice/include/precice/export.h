#pragma once
// What the library exports: its API, nothing else (it is built with hidden visibility).

#if defined(_WIN32)
#define PRECICE_API __declspec(dllimport)
#elif defined(__GNUC__)
#define PRECICE_API __attribute__((visibility("default")))
#else
#define PRECICE_API
#endif
