# Warnings and floating-point settings applied to every Wake target via wake_target_defaults().
function(wake_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow=local
                                           -Wno-unknown-pragmas -ffp-contract=off)
endfunction()
