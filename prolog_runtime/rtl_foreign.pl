:- module(rtl_foreign,
          [ rtl_load_foreign/2          % :Name, +Indicator
          ]).

/** <module> Loading the runtime's optional C helpers

The C helpers in `foreign/` (built from `c/` by `c/build.sh`) are optional: a runtime without
them (not built, another platform) does the same work in Prolog. rtl_load_foreign/2 is the
one way a runtime module loads its helper.
*/

:- meta_predicate rtl_load_foreign(:, +).

%!  rtl_load_foreign(:Name, +Indicator) is semidet.
%
%   Load the C helper `foreign/Name` of the runtime into the calling module; true when it
%   was loaded and defined Indicator there. Called from a directive of a runtime file: the
%   runtime's directory is the one of the file being loaded (source_location/2; when that is
%   a .qlf file, the load context is the file that loads it, in the same directory).

rtl_load_foreign(Module:Name, Indicator) :-
    source_location(File, _),
    file_directory_name(File, Dir),
    atomic_list_concat([Dir, '/foreign/', Name], Lib),
    absolute_file_name(Lib, _, [file_type(executable), access(read), file_errors(fail)]),
    catch(load_foreign_library(Module:Lib), _, fail),      % (use_foreign_library/1 defers the load)
    current_predicate(Module:Indicator).
