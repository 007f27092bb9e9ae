:- module(rtl_load, []).

/** <module> Loading the runtime from its precompiled files, when they are up to date

`c/build.sh` (run by `setup.sh`) compiles the runtime modules into Quick Load Files,
`rtl_*.qlf` next to their sources, which SWI-Prolog loads in a fraction of the time it takes
to compile the source (docs/runtime.md, "Start-up"). SWI-Prolog takes a `.qlf` file instead
of its `.pl` file whenever the `.qlf` file is up to date; when it is out of date (the source
was edited after the build, or the `.qlf` file was made by another SWI-Prolog version) and
writable, SWI-Prolog recompiles it while loading, printing a message and rewriting the file.

The files a program or the Python driver loads first (retalis.pl, rtl_aq.pl,
rtl_aq_api.pl) load this module first. It
finds the out-of-date `.qlf` files and loads their modules from source, by the full name of
the `.pl` file and with `.qlf` files out of sight meanwhile: nothing is printed, no file is
written, and what is loaded is always what the sources say. The up-to-date ones are then
loaded as usual, from their `.qlf` files. With no `.qlf` files (not built), this does
nothing.
*/

load_stale_from_source(Dir) :-
    atom_concat(Dir, '/*.qlf', Pattern),
    expand_file_name(Pattern, Qlfs),
    findall(Pl, ( member(Qlf, Qlfs), stale(Qlf, Pl) ), Stale),
    (   Stale == []
    ->  true
    ;   setup_call_cleanup(hide_qlf(Hidden),
                           forall(member(Pl, Stale),
                                  load_files(Pl, [if(not_loaded), imports([])])),
                           show_qlf(Hidden))
    ).

% A .qlf file that SWI-Prolog would not load as it is (its source is newer, or it is not
% compatible with this SWI-Prolog): Pl is its source.
stale(Qlf, Pl) :-
    file_name_extension(Base, qlf, Qlf),
    file_name_extension(Base, pl, Pl),
    exists_file(Pl),
    catch(system:'$qlf_out_of_date'(Pl, Qlf, _), _, true).

% While stale modules load from source, their imports do too: SWI-Prolog looks for .qlf
% files only for the extensions of user:prolog_file_type(Ext, qlf).
hide_qlf(Hidden) :-
    findall(Ext, retract(user:prolog_file_type(Ext, qlf)), Hidden).

show_qlf(Hidden) :-
    forall(member(Ext, Hidden), assertz(user:prolog_file_type(Ext, qlf))).

:- prolog_load_context(directory, Dir),
   load_stale_from_source(Dir).
