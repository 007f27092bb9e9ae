:- module(rtl_run_options, [rtl_run_option/5]).

/** <module> The run options (generated: do not edit)

Written by `python -m retalisc.run_options` from the table of retalisc/run_options.py,
where the run options are declared once; tests/test_run_options.py fails when this file
is not what the table makes. rtl_arguments.pl reads `swipl PROGRAM.pl` command lines by
these facts, and rtl_flags.pl takes the defaults of the flags from them.
*/

%!  rtl_run_option(?Option, ?Kind, ?Metavar, ?Default, ?Road) is nondet.
%
%   Option is the name after `--` (`'max-delay'`); Kind the kind of its value (switch,
%   count, seconds, limit, directory, file, labels); Metavar what the usage line calls the
%   value; Default the runtime's value when the option is not given (none: nothing);
%   Road how it reaches the runtime: flag(Flag), stream(Option), global(Key),
%   consumer_dir or action_output.

rtl_run_option('echo-input', switch, '', false, flag(echo_input)).
rtl_run_option('max-delay', seconds, 'SECONDS', 1.0, flag(max_delay)).
rtl_run_option('retraction-horizon', seconds, 'SECONDS', auto, flag(retraction_horizon)).
rtl_run_option('max-steps', count, 'N', 1000000, flag(max_steps)).
rtl_run_option('max-timers', count, 'N', 100000, flag(max_timers)).
rtl_run_option('max-event-types', count, 'N', inf, flag(max_event_types)).
rtl_run_option('max-line-bytes', count, 'N', 1048576, flag(max_line_bytes)).
rtl_run_option('max-digits', count, 'N', 4300, flag(max_digits)).
rtl_run_option('max-future', limit, 'SECONDS', 86400, flag(max_future)).
rtl_run_option('drop-pending', switch, '', false, global(rtl_drop_pending)).
rtl_run_option('flush-timers', switch, '', false, flag(flush_timers)).
rtl_run_option('allow-control', switch, '', false, stream(allow_control)).
rtl_run_option(strict, switch, '', false, stream(strict)).
rtl_run_option('consumer-dir', directory, 'DIR', none, consumer_dir).
rtl_run_option('action-output', file, 'FILE', none, action_output).
rtl_run_option(detections, labels, 'LABELS', none, global(rtl_detection_labels)).
